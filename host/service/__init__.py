"""The navigation service: goals, their states and their book (:mod:`.goals`), the service mission
(:mod:`.navigation`), its settings (:mod:`.settings`), the control socket behind ``jackson
goal``/``cancel``/``status``/``localise`` (:mod:`.control`) and the live view (:mod:`.liveview`).
"""
