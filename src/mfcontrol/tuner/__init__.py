"""The interactive tuner in the browser (``mfcontrol tuner``, the ``ui`` extra): the model
(:mod:`.session`, no web code), the Bokeh page built from it (:mod:`.page`) and the local
server (:mod:`.server`)."""
