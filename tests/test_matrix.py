"""Issue 7's "Done means": every sample and edge file x every bundled profile x {default
options, --features all} processes (exit 0), the output verifies against the input, and no
acceleration command of the output is <= 0 (nor any written line malformed). On the
Klipper-flavour runs real Klipper (../shared/klipper) reports no error and no new full stop.

The full matrix (~340 runs) is @slow; by default each file runs once and each profile at
least once (files and profiles paired round-robin, features alternating).

Refusals: none is expected. Every file here is a real slicer's output or a hand-written
edge case of what printers run (checksums, G20, G91, G10/G11, CRLF ...): each must either
be re-timed or passed through unchanged, for every flavour. An entry in EXPECTED_REFUSALS
would need its reason written next to it.
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from test_fuzz import OK, check_case, written_line_problem

ROOT = Path(__file__).resolve().parent.parent
FILES = sorted((ROOT / "sample_gcode").glob("*.gcode")) + sorted((ROOT / "sample_gcode" / "edge").glob("*.gcode"))
EXPECTED_REFUSALS: dict[tuple[str, str], str] = {}       # (file name, profile) -> why it cannot be processed


def _profiles():
    from gcode_opt.profile import profile_names
    return list(profile_names())


PROFILES = _profiles()
FULL = [(f, p, a) for f in FILES for p in PROFILES for a in (False, True)]
SUBSET = [(f, PROFILES[i % len(PROFILES)], bool(i % 2)) for i, f in enumerate(FILES)]


def _id(case):
    f, p, a = case
    return f"{f.parent.name}/{f.stem}-{p}-{'all' if a else 'default'}"


def accel_problems(path) -> list[str]:
    """Every acceleration command of a file (copied or written) whose value is <= 0 or unreadable."""
    bad = []
    with open(path, encoding="utf-8", errors="surrogateescape", newline="") as fh:
        for n, line in enumerate(fh, 1):
            head = line.lstrip()[:18].upper()
            if head.startswith("M204") or head.startswith("SET_VELOCITY_LIMIT"):
                why = written_line_problem(line)
                if why:
                    bad.append(f"line {n}: {why}")
    return bad


def run_case(case, tmp_path, oracle=False, hang_t=120.0):
    f, prof, all_ = case
    cat, detail = check_case(f.read_bytes(), prof, all_, str(tmp_path), hang_t)
    if (f.name, prof) in EXPECTED_REFUSALS:
        assert cat == "refused", (cat, detail)
        return
    assert cat == OK, f"{_id(case)}: {cat}: {detail}"
    out = tmp_path / "out.gcode"
    assert not accel_problems(out), accel_problems(out)[:5]
    if oracle:
        _oracle_check(tmp_path / "in.gcode", out, prof)


def _oracle_check(inp, out, prof):
    from gcode_opt.profile import load_profile
    profile = load_profile(prof)
    if profile.flavour != "klipper":
        return
    from klipper_oracle import full_stops, run_oracle
    before, after = run_oracle(str(inp), profile), run_oracle(str(out), profile)
    # a file Klipper itself stops on (G2 R, G20) must stop it at the same error, not a new one
    assert [e["message"] for e in after["errors"]] == [e["message"] for e in before["errors"]], after["errors"][:3]
    # no new full stop (counted at 0.01 mm/s: a reversal's junction speed below that is rounding)
    stops0, stops1 = full_stops(str(inp), profile), full_stops(str(out), profile)
    assert stops1 <= stops0, (stops0, stops1)


@pytest.mark.parametrize("case", SUBSET, ids=_id)
def test_matrix_subset(case, tmp_path):
    run_case(case, tmp_path)


def test_subset_covers_every_file_and_profile():
    assert {f for f, _, _ in SUBSET} == set(FILES)
    assert {p for _, p, _ in SUBSET} == set(PROFILES)
    assert len(FILES) >= 20 and len(PROFILES) >= 7


@pytest.mark.slow
@pytest.mark.parametrize("case", FULL, ids=_id)
def test_matrix_full(case, tmp_path):
    run_case(case, tmp_path, oracle=os.environ.get("GCODE_OPT_NO_ORACLE") is None)


# ------------------------------------------------------------------ corpus ---
CORPUS = Path(os.environ.get("GCODE_OPT_CORPUS") or
              Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "gcode-opt-corpus")
CORPUS_RUNS = {                      # file made by sample_gcode/make_corpus.sh -> the profile it was sliced for
    "gyroid_fwretract.gcode": "prusa-mk3s", "plate_rectilinear.gcode": "prusa-mk3s",
    "plate_gyroid.gcode": "prusa-mk3s", "bridges.gcode": "prusa-mk3s", "bridges_klipper.gcode": "voron24",
    "no_type_comments.gcode": "generic-klipper", "cura_gyroid.gcode": "ender3", "cura_bridges.gcode": "ender3"}


@pytest.mark.slow
@pytest.mark.parametrize("features_all", [False, True], ids=["default", "all"])
@pytest.mark.parametrize("name", sorted(CORPUS_RUNS))
def test_corpus(name, features_all, tmp_path):
    """Real large files (sample_gcode/make_corpus.sh; GCODE_OPT_CORPUS names the folder)."""
    path = CORPUS / name
    if not path.is_file():
        pytest.skip(f"no corpus file {path}: run `bash sample_gcode/make_corpus.sh {CORPUS}`")
    run_case((path, CORPUS_RUNS[name], features_all), tmp_path, oracle=path.stat().st_size < 3_000_000,
             hang_t=1800.0)
