"""Configuration: the options (declared once), their validation, and TOML in and out.

How a TOML key reaches the kernel: :mod:`.options` declares it, :mod:`.resolve` checks
it, :mod:`mfcontrol.api.params` turns the resolved configuration into the engine's arrays.
(No names are re-exported here: ``mfcontrol.config.resolve`` is the module.)
"""
