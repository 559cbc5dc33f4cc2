"""The project's input error, and the one line a command prints for it.

Every check of what a user hands in (a flag, a params field, a file, a rule sequence) raises `InputError`
with a message that names the flag, field or file and says what was expected. The entries (`robocompose`,
`robocompose.stage.run_stage`) print it as one line and exit with code 2, the code argparse uses for a bad
command line (a message over LINE_LIMIT characters cut, its start kept); Ctrl-C is one line too,
`PROGRAM: interrupted`, exit code 130. Anything else that escapes is a bug and keeps its traceback.
"""

from __future__ import annotations

INPUT_ERROR_EXIT = 2
INTERRUPTED_EXIT = 130  # 128 + SIGINT, as a shell reports a program stopped by Ctrl-C
LINE_LIMIT = 300  # characters of a message on the error line; a longer one is cut (its start names the field/file)


class InputError(ValueError):
    """Bad input: the message names the flag, field or file and what was expected vs found."""


class ArtifactError(InputError):
    """An artifact is missing, unreadable or does not match its declared contract.

    The message names the file, the column or field (if any), and what was expected vs found.
    """


def check_field(ok: bool, field: str, expected: str, found: object) -> None:
    """Raise InputError("field: expected ..., found ...") unless `ok` (a config's value checks)."""
    if not ok:
        raise InputError(f"{field}: expected {expected}, found {found!r}")


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
