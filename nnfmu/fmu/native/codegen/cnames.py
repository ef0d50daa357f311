"""Turn arbitrary ONNX names into unique C identifiers and into text that is safe inside a C block comment."""

from __future__ import annotations

import re

_NOT_IDENT = re.compile(r"[^A-Za-z0-9_]+")
MAX_STEM = 40


class NameTable:
    """Hands out unique C identifiers `<kind>_<stem>`; the kind prefix keeps them clear of keywords and digits."""

    def __init__(self) -> None:
        self._used: set[str] = set()

    def make(self, kind: str, name: str) -> str:
        """A fresh identifier for `name`, e.g. `t_fc1_weight`; a counter suffix separates names that collide."""
        stem = _NOT_IDENT.sub("_", name).strip("_")[:MAX_STEM] or "anon"
        candidate = f"{kind}_{stem}"
        counter = 1
        while candidate in self._used:
            counter += 1
            candidate = f"{kind}_{stem}_{counter}"
        self._used.add(candidate)
        return candidate


def comment_text(text: str) -> str:
    """`text` as one line of printable ASCII that cannot end or nest a C comment or form a trigraph."""
    out = []
    for char in text:
        code = ord(char)
        if char == "\\":
            out.append("\\\\")
        elif 0x20 <= code < 0x7F:
            out.append(char)
        elif code <= 0xFF:
            out.append(f"\\x{code:02x}")
        elif code <= 0xFFFF:
            out.append(f"\\u{code:04x}")
        else:
            out.append(f"\\U{code:08x}")
    line = "".join(out)
    # "*/" would close the comment, "/*" trips -Wcomment and "??" may start a trigraph in strict C99.
    line = line.replace("*/", "*\\/").replace("/*", "/\\*")
    return re.sub(r"\?(?=\?)", r"?\\", line)


def check_prefix(prefix: str) -> str:
    """Validate the symbol prefix of the generated interface (a plain C identifier)."""
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]{0,30}", prefix):
        raise ValueError(f"C symbol prefix {prefix!r} must be a letter followed by up to 30 letters, digits or _")
    return prefix
