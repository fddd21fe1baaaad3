"""The web page: play with the robot in a browser (`oxbot play`).

`server` is the FastAPI app (one robot per browser tab, over a WebSocket), `sheet` draws the
page's game sheet in Python for scripted clients, and `static/` holds the page itself.
"""
