"""Make names from an ONNX file safe for FMI variable names, C identifiers, C string literals and XML text.

An ONNX file from another tool may carry any string as a tensor or model name (quotes, `<`, `*/`, newlines). FMU
variable names follow FMI's *structured* naming convention (`x`, `x[3]`, `a_b`): every other character becomes `_`,
a name that would begin with a digit gets a leading `_`, and clashes (after sanitising, or with the FMU's built-in
variables) get a numeric suffix. The original name stays in the variable's description.
"""

from __future__ import annotations

import re

_NOT_WORD = re.compile(r"[^A-Za-z0-9_]")
_ELEMENT = re.compile(r"^(?P<base>.*)\[(?P<index>\d+)\]$", re.DOTALL)
# XML 1.0 allows tab, newline, carriage return and characters from U+0020; everything else is dropped.
_XML_ILLEGAL = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff]")


def c_identifier(name: str) -> str:
    """`name` as a C identifier: characters other than ASCII letters, digits and `_` become `_`."""
    identifier = _NOT_WORD.sub("_", name)
    if not identifier or identifier[0].isdigit():
        identifier = f"_{identifier}"
    return identifier


def fmi_variable_name(name: str) -> str:
    """`name` as an FMI structured name: `base` or `base[index]`, with `base` a C-like identifier."""
    match = _ELEMENT.match(name)
    if match:
        return f"{c_identifier(match['base'])}[{int(match['index'])}]"
    return c_identifier(name)


def unique_names(names: list[str], reserved: set[str]) -> list[str]:
    """Sanitise `names` to FMI variable names and make them distinct from each other and from `reserved`."""
    taken = set(reserved)
    result = []
    for name in names:
        candidate = fmi_variable_name(name)
        if candidate in taken:
            match = _ELEMENT.match(candidate)
            base, suffix = (match["base"], f"[{match['index']}]") if match else (candidate, "")
            n = 2
            while f"{base}_{n}{suffix}" in taken:
                n += 1
            candidate = f"{base}_{n}{suffix}"
        taken.add(candidate)
        result.append(candidate)
    return result


def xml_text(text: str) -> str:
    """`text` without the control characters XML 1.0 forbids (escaping of `<`, `&`, quotes is jinja2's job)."""
    return _XML_ILLEGAL.sub("", text)


def c_string_literal(text: str) -> str:
    """`text` as a C string literal: printable ASCII kept; `"`, `\\`, `?` (trigraphs) and other bytes in octal."""
    out = ['"']
    for byte in text.encode("utf-8"):
        char = chr(byte)
        if char.isascii() and char.isprintable() and char not in '"\\?':
            out.append(char)
        else:
            out.append(f"\\{byte:03o}")
    out.append('"')
    return "".join(out)


def c_comment(text: str) -> str:
    """`text` made safe inside a `/* ... */` comment on one line."""
    return re.sub(r"[^ -~]", "?", text).replace("*/", "*_/").replace("/*", "/_*")
