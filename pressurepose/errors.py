"""The one error type users see for bad input: it names the input and what was expected."""


class BadInput(ValueError):
    """Raised when an input (array, file, preset name, option) is not what was expected.

    The message names the input and says what was expected, e.g.
    ``pressure image has shape (60, 27); the boditrak_bt3510 mat is 64 x 27``.
    """
