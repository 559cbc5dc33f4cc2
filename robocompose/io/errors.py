"""The project's input error, and the one line a command prints for it.

Every check of what a user hands in (a flag, a params field, a file, a rule sequence) raises `InputError`
with a message that names the flag, field or file and says what was expected. The entries (`robocompose`,
`robocompose.stage.run_stage`) print it as one line and exit with code 2, the code argparse uses for a bad
command line (a message over LINE_LIMIT characters cut, its start kept); Ctrl-C is one line too,
`PROGRAM: interrupted`, exit code 130. Anything else that escapes is a bug and keeps its traceback.
"""

from __future__ import annotations

import dataclasses
import math

INPUT_ERROR_EXIT = 2
INTERRUPTED_EXIT = 130  # 128 + SIGINT, as a shell reports a program stopped by Ctrl-C
LINE_LIMIT = 300  # characters of a message on the error line; a longer one is cut (its start names the field/file)
SHOWN_CHARACTERS = 80  # an error line shows at most this much of a value's repr


class InputError(ValueError):
    """Bad input: the message names the flag, field or file and what was expected vs found."""


class ArtifactError(InputError):
    """An artifact is missing, unreadable or does not match its declared contract.

    The message names the file, the column or field (if any), and what was expected vs found.
    """


def shown(value: object, limit: int = SHOWN_CHARACTERS) -> str:
    """repr(value) for an error line, cut to `limit` characters (a huge list or string stays one short line)."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text) - limit} more characters)"


def check_field(ok: bool, field: str, expected: str, found: object) -> None:
    """Raise InputError("field: expected ..., found ...") unless `ok` (a config's value checks)."""
    if not ok:
        raise InputError(f"{field}: expected {expected}, found {shown(found)}")


def check_number(value: float, field: str, low: float | None = None, high: float | None = None,
                 bounds: str = "[]") -> None:
    """`value` is a finite number within [low, high] (`bounds` "()", "(]", "[)" or "[]" say which ends are open;
    None: no bound): else InputError("field: expected a finite number > 0, found nan") and the like. NaN and
    infinity never pass: a setting with no right answer is an error, never a fallback."""
    low_open, high_open = bounds[0] == "(", bounds[1] == ")"
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    ok = ok and (low is None or (value > low if low_open else value >= low))
    ok = ok and (high is None or (value < high if high_open else value <= high))
    if low is not None and high is not None:
        expected = f"a finite number in {bounds[0]}{low:g}, {high:g}{bounds[1]}"
    elif low is not None:
        expected = f"a finite number {'>' if low_open else '>='} {low:g}"
    elif high is not None:
        expected = f"a finite number {'<' if high_open else '<='} {high:g}"
    else:
        expected = "a finite number"
    check_field(ok, field, expected, value)


def check_finite_fields(config: object) -> None:
    """Every float field of a settings dataclass is finite (a catch-all after its ranges: NaN passes no `<`)."""
    for item in dataclasses.fields(config):  # type: ignore[arg-type]
        value = getattr(config, item.name)
        if isinstance(value, float) and not math.isfinite(value):
            check_field(False, item.name, "a finite number", value)


def error_line(program: str, error: InputError) -> str:
    """`program: error: message` on one line (a multi-line message, e.g. a YAML parser's, is joined by '; '); a
    message over LINE_LIMIT characters is cut there with an ellipsis, its start (the field or file) kept."""
    lines = [line.strip() for line in str(error).splitlines() if line.strip()]
    message = "; ".join(lines) or type(error).__name__
    if len(message) > LINE_LIMIT:
        message = message[:LINE_LIMIT - 3].rstrip() + "..."
    return f"{program}: error: {message}"


def interrupted_line(program: str) -> str:
    """The one line a command stopped by Ctrl-C prints (exit code INTERRUPTED_EXIT), on a line of its own: the
    progress bars still open (tqdm's, on stderr) are closed first, so none is redrawn after it."""
    import sys

    tqdm = sys.modules.get("tqdm")
    for bar in list(getattr(getattr(tqdm, "tqdm", None), "_instances", ())):
        try:
            bar.close()
        except Exception:  # a bar half torn down by the interrupt: its line is not worth a traceback
            pass
    return f"{program}: interrupted"
