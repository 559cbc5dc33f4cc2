"""The error every artifact reader and writer raises."""


class ArtifactError(ValueError):
    """An artifact is missing, unreadable or does not match its declared contract.

    The message names the file, the column or field (if any), and what was expected vs found.
    """
