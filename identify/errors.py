"""The one error type the command line turns into a single line on stderr."""


class UserError(Exception):
    """Bad input from the user (a file, an option, a configuration): the message is one
    line that says what is wrong and, where it can, what to do."""
