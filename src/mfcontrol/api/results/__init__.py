"""What a run gives back and how it is read: the result types (:mod:`.result`), the
metrics' columns and settling rule (:mod:`.metrics`), their text and HTML display
(:mod:`.display`), figures (:mod:`.plotting`) and what a tuner minimises over them
(:mod:`.objective`). Nothing here runs a loop or imports the objects of
:mod:`mfcontrol.api.model`.
"""
