"""What a Python user touches, in layers that import downward only: :mod:`.params` (the
translator of configuration keys to the engines' parameter arrays), :mod:`.model` (the
objects a user builds: controllers, plants, loop elements, scheduled changes),
:mod:`.results` (result types, metrics, display, figures), :mod:`.run` (running them: a
loop, a sweep, a configuration, batches) and :mod:`.interop` (python-control).
"""
