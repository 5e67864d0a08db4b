"""Errors raised at the edge of the library, worded for the person who made them."""


class ConfigError(ValueError):
    """An invalid configuration: the message names the key, the value and what is allowed.

    Parameters
    ----------
    key : str
        The option (a dotted key such as ``"controller.kp"``, or a flag such as ``--dask``).
    value : object
        The value refused.
    allowed : str
        What is allowed, in words.
    """

    def __init__(self, key: str, value: object, allowed: str):
        self.key = key
        self.value = value
        self.allowed = allowed
        super().__init__(f"{key} = {value!r}: {allowed}")


class CaseError(ValueError):
    """An unknown case name, a missing case file or a file that is not valid TOML."""
