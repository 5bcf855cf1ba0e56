"""Atheris (libFuzzer for Python) target: the experiment's file readers, tubes.experiment
.read_tracks (CSV or HDF5 tracks, with the --columns roles, time and length units, pixel size)
and read_calibration, on arbitrary bytes written to a file. Only the module's input error,
ExperimentError, may escape (the CLI turns it into a message and exit 1); any other exception is a
finding. Run by tests/fuzz/run_py.sh (make fuzz; docs/development.md "Fuzzing").
The first input byte chooses the reader and its options, the rest is the file."""
import os
import sys
import tempfile

import atheris

# what tubes.experiment imports (numpy, the rest of tubes) loaded first, uninstrumented, and the
# module itself then loaded afresh under instrumentation: the target is the readers' own code
# (instrumenting numpy and the whole package took 13 s at start and slowed every input)
import tubes.experiment  # noqa: E402

del sys.modules["tubes.experiment"]
with atheris.instrument_imports(include=["tubes.experiment"]):
    from tubes.experiment import ExperimentError, read_calibration, read_tracks

# one file per process, rewritten per input (on a RAM disk when there is one), unlinked at once and
# read through /proc/self/fd: libFuzzer ends the process with exit(), which runs no Python clean-up
_DIR = "/dev/shm" if os.access("/dev/shm", os.W_OK) else None
_FD, _name = tempfile.mkstemp(prefix="fuzz_tracks_", dir=_DIR)
os.unlink(_name)
_PATH = f"/proc/self/fd/{_FD}"
COLUMNS = [None, {"track": "id", "t": "time_ms", "x": "x_mm", "y": "y_mm"}, {"t": "frame"}, {"x": "y", "y": "x"}]
TIME_UNITS = ["s", "ms", "us", "min"]          # "min" is not allowed: the error path
LENGTHS = [("cm", None), ("mm", None), ("px", 0.01), ("px", None)]   # px without a size: error


def TestOneInput(data: bytes) -> None:
    if not data:
        return
    opt, body = data[0], data[1:]
    os.ftruncate(_FD, 0)
    os.pwrite(_FD, body, 0)
    unit, psize = LENGTHS[(opt >> 4) & 3]
    try:
        if opt & 0x80:
            read_calibration(_PATH, length_unit=unit, pixel_size=psize)
        else:
            read_tracks(_PATH, columns=COLUMNS[opt & 3], time_unit=TIME_UNITS[(opt >> 2) & 3],
                        length_unit=unit, pixel_size=psize)
    except ExperimentError:
        pass


if __name__ == "__main__":
    atheris.Setup(sys.argv, TestOneInput)
    atheris.Fuzz()
