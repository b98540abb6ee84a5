"""The one atomic writer: a folder or a file in the way is named, and nothing is left behind."""

from __future__ import annotations

import pytest

from benchmarks.storage import atomic_write_bytes, atomic_write_text


def test_a_folder_at_the_path_is_refused_by_name_and_nothing_is_left(tmp_path):
    target = tmp_path / "out"
    target.mkdir()
    with pytest.raises(IsADirectoryError, match=f"{target} is a folder"):
        atomic_write_text(target, "text")
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_a_file_where_a_folder_is_needed_is_named(tmp_path):
    (tmp_path / "notes").write_text("a file")
    with pytest.raises(NotADirectoryError, match="notes is a file, not a folder"):
        atomic_write_bytes(tmp_path / "notes" / "sub" / "x.bin", b"data")
    assert [p.name for p in tmp_path.iterdir()] == ["notes"]


def test_the_one_csv_writer_round_trips_floats_bit_for_bit():
    import io

    import numpy as np
    import pandas as pd

    from benchmarks.storage.table import csv_text

    values = [0.1 + 0.2, 1e-300, -2.5e17, float("nan"), 1 / 3]
    text = csv_text(pd.DataFrame({"x": values, "name": ["NA", "a", "b", "c", "d"]}))
    assert text.startswith("x,name\n") and "\r" not in text
    from benchmarks.storage.table import _CSV_FLOAT_KW  # round-trip parsing on pandas < 3

    back = pd.read_csv(
        io.StringIO(text), keep_default_na=False, na_values={"x": [""]}, **_CSV_FLOAT_KW
    )
    np.testing.assert_array_equal(back["x"].to_numpy(), np.array(values))
    assert back["name"].tolist() == ["NA", "a", "b", "c", "d"]
