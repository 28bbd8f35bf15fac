"""Sequences of primitive actions (`world/actions.py`): drawn uniform in the action box, or
read from a file and refused, with the row named, when one leaves it."""

from __future__ import annotations

import numpy as np
import pytest

from hadim_cli.errors import ActionError, HadimError
from hadim_cli.world.actions import load_actions, random_actions


def test_random_actions_are_uniform_in_the_action_box_and_a_function_of_the_generator():
    a = random_actions(np.random.default_rng(0), 4000)
    assert a.shape == (4000, 2)
    assert np.all(np.abs(a) <= 1.0) and np.all(a.min(axis=0) < -0.99) \
        and np.all(a.max(axis=0) > 0.99)
    np.testing.assert_allclose(a.mean(axis=0), 0.0, atol=0.04)
    np.testing.assert_allclose(a.var(axis=0), 1 / 3, atol=0.02)
    assert abs(np.corrcoef(a.T)[0, 1]) < 0.05
    assert np.array_equal(a, random_actions(np.random.default_rng(0), 4000))


@pytest.mark.parametrize("suffix", [".csv", ".txt", ".npy"])
def test_an_actions_file_is_read_as_rows_of_two_intensities(tmp_path, suffix):
    want = np.array([[1.0, -1.0], [0.25, 0.5], [-0.75, 0.0]])
    path = tmp_path / f"a{suffix}"
    if suffix == ".npy":
        np.save(path, want)
    else:
        path.write_text("\n".join(("{}, {}" if suffix == ".csv" else "{} {}").format(*r)
                                  for r in want))
    got = load_actions(path)
    assert got.dtype == np.float64 and np.array_equal(got, want)


def test_whole_numbers_are_read_as_intensities(tmp_path):
    path = tmp_path / "ints.npy"
    np.save(path, np.array([[1, 0], [0, -1]]))
    got = load_actions(path)
    assert got.dtype == np.float64 and np.array_equal(got, [[1.0, 0.0], [0.0, -1.0]])


def test_a_single_row_file_is_one_action(tmp_path):
    path = tmp_path / "one.txt"
    path.write_text("0.5 -0.5\n")
    assert np.array_equal(load_actions(path), [[0.5, -0.5]])


def test_bad_actions_files_are_refused_with_what_is_wrong(tmp_path):
    with pytest.raises(HadimError, match="not found"):
        load_actions(tmp_path / "missing.csv")
    three = tmp_path / "three.csv"
    three.write_text("0 0 0\n")
    with pytest.raises(HadimError, match=r"N rows of 2 intensities .* shape \(1, 3\)"):
        load_actions(three)
    words = tmp_path / "words.csv"
    words.write_text("left right\n")
    with pytest.raises(HadimError, match="cannot read actions"):
        load_actions(words)
    out = tmp_path / "out.csv"
    out.write_text("0.5, 0.5\n1.0, -1.0\n1.5, 0\n")
    with pytest.raises(ActionError, match=r"row 3: \[1.5, 0.0\] is not in \[-1, 1\]²"):
        load_actions(out)
    nan = tmp_path / "nan.csv"
    nan.write_text("0, 0\nnan, 0\n")
    with pytest.raises(ActionError, match=r"row 2: \[nan, 0.0\]"):
        load_actions(nan)
    pickled = tmp_path / "pickled.npy"  # a .npy of Python objects is never unpickled
    np.save(pickled, np.array([[0.5, 0.5]], dtype=object), allow_pickle=True)
    with pytest.raises(HadimError, match="cannot read actions"):
        load_actions(pickled)
    edge = tmp_path / "edge.csv"
    edge.write_text("-1, 1\n")
    assert np.array_equal(load_actions(edge), [[-1.0, 1.0]])
