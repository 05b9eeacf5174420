"""A short fixed-seed profile of the file-reader fuzz (issue 19; engine and contract in
`reader_fuzzing.py`, the 10^4-case run in `benches/fuzz_readers.py`).

Every reader gets `CASES` mutated real files in a worker process: each must read or be refused with
a documented exception whose one-line message names the file, within 5 s and 256 MiB a case, no
crash. A control target that breaks the contract on purpose checks that the harness catches an
undocumented exception, a segfault, a hang and a memory hog, and saves each input.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import reader_fuzzing as fuzz

CASES = 100
"""Cases per reader: about 40 s for all the readers (a worker starts in about 2 s)."""


@pytest.mark.parametrize("reader", fuzz.READERS)
def test_a_reader_keeps_its_contract_on_mutated_files(reader: str, tmp_path: Path) -> None:
    report = fuzz.run_target(reader, CASES, seed=0, failures=tmp_path)
    failed = "\n".join(f"case {index}: {what[:300]}" for index, what in report.failures)
    assert not report.failures, (
        f"{reader}: {failed}\n(inputs and tracebacks under {tmp_path}; replay with "
        f"{fuzz.replay_command(reader, 0, report.failures[0][0])})"
    )
    assert report.cases == CASES
    # The mutations reach both sides of every reader: files it reads, and files it refuses.
    refusals = [kind for kind in report.classes if kind != "ok"]
    assert report.classes["ok"] > 0, report.classes
    if reader != "plan_cache":  # a damaged cache entry is rebuilt, never refused
        assert len(refusals) >= 3, report.classes


def test_the_harness_catches_an_exception_a_crash_a_hang_and_a_memory_hog(tmp_path: Path) -> None:
    # 3 s a case: a loaded machine (other jobs on both cores) once took over 1 s for a sound case.
    report = fuzz.run_target("_control", 5, seed=0, failures=tmp_path, case_seconds=3.0)
    failures = dict(report.failures)
    assert sorted(failures) == [1, 2, 3, 4] and report.cases == 5, report.failures
    assert failures[1].startswith("undocumented builtins.KeyError: 'an undocumented exception'")
    assert failures[2] == "crash: worker exit -11 (SIGSEGV)"
    assert failures[3] == "no result after 3.0 s"
    assert failures[4].startswith("took 30") and failures[4].endswith("MiB of memory (bound 256 MiB)"), failures[4]
    for index in (1, 2, 3, 4):
        saved = tmp_path / f"_control-s0-c{index}"
        assert (saved / "input" / "x.txt").is_file()
        assert f"--reader _control --seed 0 --replay {index}" in (saved / "failure.txt").read_text()
    assert "KeyError" in (tmp_path / "_control-s0-c1" / "failure.txt").read_text()  # the traceback
