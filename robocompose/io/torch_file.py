"""Torch files (models, generators, Q-networks) behind the checksum header of `robocompose.io.checked`.

    save_torch(obj, "models/m.pt")    # torch.save behind a SHA-256 header, atomically, the same bytes every run
    obj = load_torch("models/m.pt")   # tensors and plain data only (weights_only=True): never code

A flipped byte inside a tensor is read by torch.load without complaint; the header catches it first (an
ArtifactError naming the file). torch is imported on first use, so importing this module stays cheap.
"""

from __future__ import annotations

import io
import os
import pickle
from pathlib import Path

from robocompose.io.checked import read_checked, write_checked
from robocompose.io.errors import ArtifactError


def torch_bytes(obj: object) -> bytes:
    """torch.save of `obj` through memory: the bytes do not depend on the file name (torch names the archive's
    folder after the file it writes, which for an atomic write is a random temporary name)."""
    import torch

    buffer = io.BytesIO()
    torch.save(obj, buffer)
    return buffer.getvalue()


def load_torch_bytes(payload: bytes, source: str | os.PathLike[str]) -> object:
    """torch.load of `payload` (read from file `source`) with weights_only=True, on the CPU: tensors and plain
    containers, never arbitrary objects. ArtifactError naming the file for anything else."""
    import torch

    try:
        return torch.load(io.BytesIO(payload), map_location="cpu", weights_only=True)
    except pickle.UnpicklingError:
        raise ArtifactError(f"{source}: holds Python objects other than tensors and plain values, which are not "
                            "loaded (torch files load with weights_only=True)") from None
    except Exception as err:  # an intact checksum over a payload that is no torch archive: torch raises many types
        raise ArtifactError(f"{source}: damaged torch archive ({type(err).__name__})") from None


def save_torch(obj: object, path: str | os.PathLike[str]) -> Path:
    """torch.save `obj` to `path` behind the checksum header, atomically; return the path."""
    return write_checked(path, torch_bytes(obj))


def load_torch(path: str | os.PathLike[str]) -> object:
    """What `save_torch` wrote, as `load_torch_bytes` loads it; ArtifactError naming the file if it is truncated,
    corrupted or holds other objects, FileNotFoundError if it is missing."""
    return load_torch_bytes(read_checked(path), path)
