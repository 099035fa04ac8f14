"""Reading a text file a user names, with one clear line for what cannot be read: a
missing or unreadable file, bytes that are not text (the line they are on), binary data."""

from __future__ import annotations

import re
from pathlib import Path

from sim.errors import ConfigError

_BINARY = re.compile(r"[\x00-\x08\x0e-\x19\x1c-\x1f\x7f]")


def read_text(path, what: str = "file", encoding: str = "utf-8", error=ConfigError, binary_check: bool = True) -> str:
    """The text of ``path``.

    Parameters
    ----------
    path : the file.
    what : how messages name it (``"vehicle file"``).
    encoding : ``"utf-8"`` (strict) or ``"latin-1"`` (every byte decodes; then only the
        binary check can fail).
    error : the exception class raised (one-line message naming the file and the line).
    binary_check : refuse control characters other than tab, line ends, form feed and
        escape (NUL and friends: a binary file, not text).
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except IsADirectoryError:
        raise error(f"{what} {path} is a folder, not a file") from None
    except OSError as err:
        raise error(f"cannot read {what} {path}: {err.strerror or err}") from None
    try:
        text = data.decode(encoding)
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        raise error(f"{what} {path}: line {line} holds bytes that are not {encoding.upper()} text "
                    f"(0x{data[err.start]:02x}); is it the right file?") from None
    if binary_check:
        m = _BINARY.search(text)
        if m is not None:
            line = text.count("\n", 0, m.start()) + 1
            raise error(f"{what} {path}: line {line} holds binary data (0x{ord(m.group()):02x}), not text; "
                        "is it the right file?")
    return text
