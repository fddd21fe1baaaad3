"""A user study in the box (`oxbot study`, docs/study.md): consent, a random participant id,
questions before the games, the games in counterbalanced conditions (the manager, who starts,
voice or typing), standard questionnaires after each condition (SUS, Godspeed), metrics
measured on every game, an experimenter's page, export and forgetting.

    from oxbot.study.store import StudyStore         # study.sqlite3: participants, answers, games
    from oxbot.study.conditions import Design        # the conditions and their rotation
    from oxbot.study.instruments import score        # SUS and Godspeed, scored by their authors
"""
