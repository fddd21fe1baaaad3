"""The web page: play with the robot in a browser (`oxbot play`).

`server` is the FastAPI app and its routes, and serves it; `session` runs one browser tab's game
over a WebSocket (one robot per tab) and documents the protocol; `inbound` checks what a tab
sends; `admission` decides who may open a session; `memory` hands closed sessions' memory back;
`recording` is the record toggle and the "what I learned" page; `tls` the HTTPS certificate.
`static/` holds the page itself (the page's sheet in Python is oxbot.testing.sheet).
"""
