"""Which strings a vessel may send: the one rule for every string the boat API takes. Pure.

PostgreSQL can store neither NUL (in text or jsonb) nor a lone UTF-16 surrogate (a valid JSON
escape such as ``\\ud800``, but not Unicode): the INSERT fails, a 500 that also cost the rest
of a batch. SQLite keeps both, and every page showing them then fails to render. So the boat
API refuses them, with a clear error naming the field (DRF's own CharField already does, in
these words), and never rewrites what a vessel sent. Text the shore reads from its own
hardware (a modem's SMS, the C&C box) is another matter: it is kept with U+FFFD in their place.
"""

from __future__ import annotations

import json
import re
from typing import Any

NUL_MESSAGE = "Null characters are not allowed."
# How deeply a stored JSON value may nest. The deepest the boats send is a mission's params
# (params → items → item → value: 3); the SMS language's parsed is shallower. Deeper values
# are refused here because the JSON parser takes nesting the ORM's encoder then cannot write
# (about 890 levels: a RecursionError, a 500 that cost the rest of a batch).
JSON_MAX_DEPTH = 32
_SURROGATE = re.compile("[\ud800-\udfff]")
# Both at once: what no stored text may hold.
UNSTORABLE = re.compile("[\x00\ud800-\udfff]")


def unstorable(text: str) -> str | None:
    """Why ``text`` cannot be stored (the words of DRF's CharField), or None if it can."""
    if "\x00" in text:
        return NUL_MESSAGE
    if found := _SURROGATE.search(text):
        return f"Surrogate characters are not allowed: U+{ord(found.group()):X}."
    return None


def replace_unstorable(text: str) -> str:
    """``text`` with NUL and lone surrogates as U+FFFD: for text the shore reads from its own
    hardware (a modem, the C&C box) or keeps as a note, which is logged rather than refused."""
    return UNSTORABLE.sub("\ufffd", text)


def json_unstorable(value: Any) -> str | None:
    """Why a parsed JSON value cannot be stored, naming where (``[0].k``), or None.

    Every string is checked, object keys included, and the nesting is at most JSON_MAX_DEPTH.
    A loop over a stack rather than recursion: the JSON parser allows nesting deeper than
    Python's recursion limit would.
    """
    stack: list[tuple[str, Any, int]] = [("", value, 0)]
    while stack:
        where, item, depth = stack.pop()
        if depth >= JSON_MAX_DEPTH and isinstance(item, dict | list):
            return f"{where or 'value'}: nested deeper than {JSON_MAX_DEPTH} levels"
        if isinstance(item, str):
            if problem := unstorable(item):
                return f"{where or 'value'}: {problem}"
        elif isinstance(item, dict):
            for key in item:
                if problem := unstorable(str(key)):
                    return f"key '{shown(str(key))}'{f' in {where}' if where else ''}: {problem}"
            # Reversed onto the stack: the first problem in reading order is the one named.
            stack.extend(
                (f"{where}.{k}" if where else str(k), v, depth + 1)
                for k, v in reversed(item.items())
            )
        elif isinstance(item, list):
            stack.extend(
                (f"{where}[{i}]", v, depth + 1) for i, v in reversed(list(enumerate(item)))
            )
    return None


def json_size(value: Any) -> int:
    """Bytes of ``value`` as compact UTF-8 JSON: the measure of a stored JSON field's limit."""
    text = json.dumps(value, ensure_ascii=False, separators=(",", ":"))
    return len(text.encode("utf-8", "surrogatepass"))


def shown(text: str) -> str:
    """``text`` fit to echo in a reply: NUL and lone surrogates spelled as escapes."""
    return text.replace("\x00", "\\x00").encode("utf-8", "backslashreplace").decode("utf-8")
