"""Property-based fuzzing (Hypothesis) of the experiment's track reader (tubes.experiment
.read_tracks): whatever bytes a file holds, the reader returns tracks or raises the module's
input error (ExperimentError, which `python -m tubes.experiment` turns into a message and exit 1),
never another exception. TUBES_FUZZ_EXAMPLES sets the number of examples per property (default
300; docs/development.md records a long run)."""
import base64
import os
import zlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from tubes.experiment import ExperimentError, read_tracks

N = int(os.environ.get("TUBES_FUZZ_EXAMPLES", "300"))
SETTINGS = settings(max_examples=N, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

CELL = st.one_of(
    st.integers(-5, 50).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["", " ", "nan", "inf", "-0", "1e400", "0x10", "1,5", "\"3\"", "#", "track", "t"]),
    st.text(max_size=6),
)
HEADERS = st.one_of(
    st.just(["track", "t", "x", "y"]),
    st.permutations(["track", "t", "x", "y"]).map(list),
    st.lists(st.sampled_from(["track", "t", "x", "y", "frame", "time_s", "x_cm", "", "T"]), max_size=6),
)


def _read(tmp_path, data: bytes):
    p = tmp_path / "tracks.csv"
    p.write_bytes(data)
    try:
        tr = read_tracks(str(p))
    except ExperimentError:
        return None
    # what is returned is consistent: four columns of one length, integer track ids
    n = len(tr.t)
    assert n > 0 and len(tr.track) == len(tr.x) == len(tr.y) == n
    assert np.issubdtype(np.asarray(tr.track).dtype, np.integer)
    return tr


@SETTINGS
@given(data=st.binary(max_size=400))
def test_any_bytes_give_tracks_or_a_clean_error(tmp_path_factory, data):
    _read(tmp_path_factory.mktemp("b"), data)


@SETTINGS
@given(header=HEADERS, rows=st.lists(st.lists(CELL, min_size=0, max_size=6), max_size=12),
       sep=st.sampled_from([",", ";", "\t", " "]), eol=st.sampled_from(["\n", "\r\n", "\r"]))
def test_csv_like_text_gives_tracks_or_a_clean_error(tmp_path_factory, header, rows, sep, eol):
    text = eol.join(sep.join(r) for r in [header, *rows]) + eol
    _read(tmp_path_factory.mktemp("t"), text.encode("utf-8", "surrogatepass"))


@SETTINGS
@given(rows=st.lists(st.tuples(st.integers(0, 3), st.floats(-1e3, 1e3), st.floats(-30, 30),
                               st.floats(-30, 30)), min_size=1, max_size=20))
def test_a_well_formed_file_is_read_back_exactly(tmp_path_factory, rows):
    text = "track,t,x,y\n" + "".join(f"{k},{t!r},{x!r},{y!r}\n" for k, t, x, y in rows)
    tr = _read(tmp_path_factory.mktemp("w"), text.encode())
    assert tr is not None
    got = sorted(zip(tr.track.tolist(), tr.t.tolist(), tr.x.tolist(), tr.y.tolist()))
    assert got == sorted((k, t, x, y) for k, t, x, y in rows)


# Found by the Atheris target tests/fuzz/fuzz_tracks.py (docs/development.md "Fuzzing"): HDF5 files
# of tracks whose structure is damaged, on which h5py raised RuntimeError ("bad symbol table node
# signature") and ValueError ("Insufficient precision in available types") through read_tracks.
# The files are the fuzzer's inputs (less its first, option byte), zlib-compressed and base64-coded.
DAMAGED_H5 = {
    "bad_symbol_table_node": (
        'eNrr9HBx4+WS4mIAAQ4OBhYGAQZk8B8KBHhR+TD5BCjNCKU7oPQKJpg4I1hOAiouCDUfXV1IkKsrSPV/NACz5wErhOZgGAUjEXi4OgaA6AgoH5ZKTzChqispSkzOLkakRw8K7cWVfj2YIfwMVuLSbwA04SqMRuVo+gUCDVh5yYol/YJoKL8CSleilbMGDAzKCsn5ubmpeSVcYE0KJQoVCpVcBgoGCoYKRlwgEkjbcvm7gFIwrNxUYEY1Bz0djwJc5QArJMwYYXxIicDICBGABiMSLQBWKsABq7McwCQrkAcSZ2JiYoTUZxBzmBktoFEkgWbzhCESPhAQ7AdKb4hWxAxO/Ppg6VKDHb86WKgc4MKvDla+vuAeaelNAqxUUMEent5MuBlM/kMV4E53K7iwp7uOQRw6H+zpH04XuIdOOMHDxwGayxzoF04/eIZeekKEGwDDpGXw'),
    "unknown_float_type": (
        'eNrr9HBx4+WS4mIAAQ4OBhYGAQZk8B8KBHhR+TD5BCjNCKU7oPQKJpg4I1hOAiouCDUfXV1IkKsrSPV/NACz5wErhOZgGAUjEXi4OgaA6AgoH5ZKTzChqispSkzOLkakRw8K7cWVfj2YIfwMVuLSbwA04SqMRuVo+gUCDVh5yYol/YJoKL8CSleilbMGRNob7OfvAkrBsHJTgRnVHPR0PApwlQOskDBjhPEhJQIjI0QAGoxItABYqQAHrM5yAJOsQB5InImJiRFSn0HMYWa0gEaRBJrNE4ZI+CCnN0QrYgYnfn2wdKnBjl8dLFQOcOFXBytfX3CPtPQmAVYqqGAPT28m3Awm/6EKcKe7FVzY013HIA6dD/Y0CCcm/OF0gXvohBM8fBygucyBfunpB8/QS0+IcAMAf2Rc1w=='),
}


@pytest.mark.parametrize("name", sorted(DAMAGED_H5))
def test_a_damaged_hdf5_file_gives_a_clean_error(tmp_path, name):
    data = zlib.decompress(base64.b64decode(DAMAGED_H5[name]))
    assert data[:8] == b"\x89HDF\r\n\x1a\n"
    p = tmp_path / "tracks.h5"
    p.write_bytes(data)
    with pytest.raises(ExperimentError, match="damaged HDF5 file"):
        read_tracks(str(p))
