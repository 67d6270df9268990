"""A SIMROBOT robot's memory in the editor (no GUI): the original's Memory menu (info, load from
disk, save to disk, clear). The memory is written into the world file (the robot's ``memory``)
and is what the robot's algorithm reads with ``readmem`` from the first step.

Files are the original's two kinds: a MAT-file holding a variable ``mem``, or ASCII text (one row
of numbers a line, separated by spaces or commas), read and written in the workspace only.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from sim_runtime.errors import InputError
from simrobot_sim.world_file import MAX_MEMORY_VALUES, read_memory
from studio.shell.workspace import MAX_UPLOAD_BYTES, Workspace

Memory = tuple[tuple[float, ...], ...]
MAT_SUFFIX = ".mat"


def memory_info(memory: Memory | None) -> str:
    """The original's Memory info: the matrix's size, bytes and class."""
    if memory is None:
        return "memory: empty"
    rows, cols = len(memory), len(memory[0])
    return f"memory: {rows} x {cols} double ({8 * rows * cols} bytes)"


def as_memory(values: np.ndarray, name: str) -> Memory:
    """A loaded matrix as a robot's memory; InputError naming the file when it cannot be one."""
    array = np.asarray(values)
    if array.dtype.kind not in "biuf" or array.ndim > 2:
        raise InputError(
            f"{name}: the memory must be a matrix of numbers (got {array.dtype} of {array.ndim} dimensions)"
        )
    if array.size == 0:
        raise InputError(f"{name}: the memory is empty: use Clear memory to empty it")
    if array.size > MAX_MEMORY_VALUES:
        raise InputError(f"{name}: {array.size} numbers, more than {MAX_MEMORY_VALUES} a world file holds")
    rows = np.atleast_2d(array.astype(float)).tolist()
    memory = read_memory(rows, name)
    assert memory is not None
    return memory


def load_memory(workspace: Workspace, name: str) -> Memory:
    """Memory contents from the workspace file ``name`` (MAT with ``mem``, or ASCII)."""
    path = workspace.path(name)
    if not path.is_file():
        raise InputError(f"{name}: no such file in the workspace: type the name of a .mat or text file")
    if path.stat().st_size > MAX_UPLOAD_BYTES:
        raise InputError(f"{name}: larger than {MAX_UPLOAD_BYTES} bytes: a robot's memory is a small matrix")
    if path.suffix.lower() == MAT_SUFFIX:
        from scipy.io import loadmat

        try:
            variables = loadmat(io.BytesIO(path.read_bytes()))
        except Exception:  # scipy raises many types for a file that is not a MAT-file
            raise InputError(
                f"{name}: not a MAT-file: save it in MATLAB or Octave with save('{name}', 'mem')"
            ) from None
        if "mem" not in variables:
            raise InputError(f"{name}: holds no variable mem: save the memory as mem, e.g. save('{name}', 'mem')")
        return as_memory(variables["mem"], name)
    text, _ = workspace.read_text(name, "memory")
    try:
        values = np.loadtxt(io.StringIO(text.replace(",", " ")), dtype=float, ndmin=2)
    except ValueError as err:
        raise InputError(f"{name}: not rows of numbers ({err}): write one row of numbers a line") from None
    return as_memory(values, name)


def save_memory(workspace: Workspace, name: str, memory: Memory | None, overwrite: bool) -> Path:
    """Write ``memory`` to the workspace file ``name`` (MAT as ``mem`` for .mat, else ASCII)."""
    if memory is None:
        raise InputError("the robot's memory is empty: nothing to save (Load a file into it first)")
    path = workspace.path(name)
    if path.exists() and not overwrite:
        raise InputError(f"{name}: file exists (tick 'overwrite' to replace it)")
    array = np.array(memory, dtype=float)
    if path.suffix.lower() == MAT_SUFFIX:
        from scipy.io import savemat

        path.parent.mkdir(parents=True, exist_ok=True)
        savemat(path, {"mem": array})
        return path
    out = io.StringIO()
    np.savetxt(out, array, fmt="%.17g")
    return workspace.write_text(name, out.getvalue(), overwrite=overwrite)
