"""rclpy's exception names, for the errors our runtime raises."""
from __future__ import annotations


class ExternalShutdownException(Exception):
    """The context was shut down (Ctrl-C, SIGTERM or rclpy.shutdown) while spinning."""


class NotInitializedException(Exception):
    """init() has not been called (or the context is shut down)."""


class ParameterException(Exception):
    """Base of the parameter errors; carries the parameter name."""

    def __init__(self, message: str, name: str = "") -> None:
        super().__init__(message)
        self.name = name


class ParameterNotDeclaredException(ParameterException):
    def __init__(self, name: str) -> None:
        super().__init__(f"parameter '{name}' is not declared", name)


class ParameterAlreadyDeclaredException(ParameterException):
    def __init__(self, name: str) -> None:
        super().__init__(f"parameter '{name}' has already been declared", name)


class ParameterUninitializedException(ParameterException):
    def __init__(self, name: str) -> None:
        super().__init__(f"parameter '{name}' is declared without a value", name)


class InvalidParameterTypeException(ParameterException):
    def __init__(self, name: str, reason: str) -> None:
        super().__init__(f"parameter '{name}': {reason}", name)


class InvalidParameterValueException(ParameterException):
    def __init__(self, name: str, value: object, reason: str) -> None:
        super().__init__(f"invalid value {value!r} for parameter '{name}': {reason}", name)
        self.value = value
        self.reason = reason


class InvalidRosArgumentsError(ValueError):
    """A malformed or unknown argument after --ros-args (init() turns it into exit code 2)."""
