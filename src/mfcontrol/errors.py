"""Errors raised at the edge of the library, worded for the person who made them."""


class ConfigError(ValueError):
    """An invalid configuration: the message names the key, the value and what is allowed."""

    def __init__(self, key: str, value: object, allowed: str):
        self.key = key
        self.value = value
        self.allowed = allowed
        super().__init__(f"{key} = {value!r}: {allowed}")


class CaseError(ValueError):
    """An unknown case name, a missing case file or a file that is not valid TOML."""
