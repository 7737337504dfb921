"""results.csv written row by row (ROS-free): appended and flushed as runs finish, kept by --resume, a torn
last line dropped, a run never counted twice."""
import csv
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from landing_eval.results_store import CSV_FIELDS, ResultsFile, ResultsFileError  # noqa: E402


def row(name, run=1, outcome="landed_on_pad", error=0.05):
    return {"name": name, "run": run, "file": name + ".yaml", "vehicle": "summit_xl", "path": "circle",
            "speed_mps": 1.0, "wind_speed": 0.0, "outcome": outcome, "expected": '"landed_on_pad"',
            "passed": outcome == "landed_on_pad", "touchdown_error_m": error, "time_to_land_s": 30.0, "decisions": 2,
            "emergency_position": None, "sim_time_s": 40.0, "wall_time_s": 12.0, "real_time_factor": 4.0,
            "node": "host", "error": ""}


def lines(path):
    with open(path, newline="") as stream:
        return list(csv.DictReader(stream))


def test_each_row_is_on_disk_as_soon_as_it_is_appended(tmp_path):
    path = str(tmp_path / "results.csv")
    store = ResultsFile(path, resume=False)
    assert store.append(row("a"))
    assert [r["name"] for r in lines(path)] == ["a"]  # still open: flushed, not buffered
    assert store.append(row("b"))
    assert [r["name"] for r in lines(path)] == ["a", "b"]
    store.close()


def test_a_run_already_written_is_not_written_again(tmp_path):
    path = str(tmp_path / "results.csv")
    with ResultsFile(path, resume=False) as store:
        assert store.append(row("a"))
        assert not store.append(row("a", outcome="timeout"))  # e.g. a task's second result
        assert store.append(row("a", run=2))
    assert [(r["name"], r["run"], r["outcome"]) for r in lines(path)] == [("a", "1", "landed_on_pad"),
                                                                           ("a", "2", "landed_on_pad")]


def test_resume_keeps_finished_rows_with_their_types_and_drops_a_torn_last_line(tmp_path):
    path = str(tmp_path / "results.csv")
    with ResultsFile(path, resume=False) as store:
        store.append(row("a"))
        store.append(row("b", outcome="timeout", error=None))
    with open(path, "a") as stream:
        stream.write("c,1,c.yaml,summit_xl,circ")  # the sweep was killed while writing this line
    store = ResultsFile(path, resume=True)
    assert store.done == {("a", 1), ("b", 1)}
    a, b = store.rows
    assert a["passed"] is True and a["touchdown_error_m"] == 0.05 and a["decisions"] == 2 and a["run"] == 1
    assert b["passed"] is False and b["touchdown_error_m"] is None
    assert store.append(row("c"))
    store.close()
    assert [r["name"] for r in lines(path)] == ["a", "b", "c"]


def test_without_resume_the_file_starts_anew(tmp_path):
    path = str(tmp_path / "results.csv")
    with ResultsFile(path, resume=False) as store:
        store.append(row("a"))
    with ResultsFile(path, resume=False) as store:
        assert store.rows == [] and store.append(row("a"))
    assert len(lines(path)) == 1


def test_resume_refuses_a_file_with_other_columns(tmp_path):
    path = tmp_path / "results.csv"
    path.write_text("name,file,outcome\na,a.yaml,timeout\n")
    with pytest.raises(ResultsFileError, match="start a new --out"):
        ResultsFile(str(path), resume=True)
    assert path.read_text() == "name,file,outcome\na,a.yaml,timeout\n"  # untouched
    assert "run" in CSV_FIELDS and "node" in CSV_FIELDS
