"""The transcription of the vehicle models into one NLP (paper §3.4-3.6, eq. 14): the
collocation grid (:mod:`~suspopt.transcription.grid`), one Dymos phase per scenario
(:mod:`~suspopt.transcription.phase`) and the problem that shares the design among them
(:mod:`~suspopt.transcription.problem`)."""
