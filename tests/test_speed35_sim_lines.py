"""analyse's chunks as bytes (issue 8, round 35), same bits:

- state.line_chunks yields the compiled reader's Lines (split_block: the chunk's bytes and
  where each line starts) instead of a list of str: as a sequence it must be split_lines'
  list (the same str, endings and bad UTF-8 included) with the same bytes used;
- the compiled model's run_lines and gap_lines read a Lines' lines as bytes (no str a
  line): analyse must give the reference's strokes, sums and tallies field by field where
  lines are not ASCII (such a line's peek is Python's, as a str of other characters was),
  where they end in "\\r\\n", and at every chunk size; and the C loops must still read
  nearly every line (else the test would pass with Python reading them all)."""
from __future__ import annotations

import random

import pytest

from gcode_opt import pipeline as pl
from gcode_opt import state
from gcode_opt.firmware import simulate as fwsim
from test_speed_analyse2_runs import COMPILED, SAMPLES, _same, _Taken

needs_reader = pytest.mark.skipif(getattr(state._reader, "split_block", None) is None,
                                  reason="the compiled reader is not built")


# ---------------------------------------------------------------- Lines is split_lines' list
def _texts():
    rng = random.Random(35)
    alpha = [b"\r", b"\n", b"\r\n", b"a", b"G1 X1.5 Y2 E.1\n", b";c", b"\xc3\xa9", b"\xe2\x82\xac", b"\xff", b"\xe2"]
    texts = [b"", b"a", b"a\n", b"a\r", b"a\r\n", b"\r\n\r\n", b"x\ry\r\nz\nw", b"\xe2\x82\n\xff\r\xc3\xa9\r\n"]
    texts += [b"".join(rng.choice(alpha) for _ in range(rng.randint(1, 300))) for _ in range(100)]
    texts += [b"".join(rng.choice(alpha[:6]) for _ in range(rng.randint(1, 300))) for _ in range(100)]
    return texts


@needs_reader
@pytest.mark.parametrize("final", [False, True])
def test_lines_are_split_lines(final):
    r = state._reader
    for t in _texts():
        want, want_used = r.split_lines(t, final)
        got, used = r.split_block(t, final)
        assert type(got) is r.Lines
        assert used == want_used and len(got) == len(want), t
        assert list(got) == want and [got[i] for i in range(len(got))] == want, t
        if want:
            assert got[-1] == want[-1]
        with pytest.raises(IndexError):
            got[len(want)]


@needs_reader
def test_lines_hold_their_bytes():
    """A Lines keeps the bytes it was made of (no copy): its lines outlive the caller's name."""
    data = b"G1 X1\nG1 X2\r\nM204 S3\n\xc3\xa9\n"
    got, used = state._reader.split_block(bytes(bytearray(data)), True)
    assert used == len(data)
    assert list(got) == ["G1 X1\n", "G1 X2\r\n", "M204 S3\n", "\u00e9\n"]
    with pytest.raises(TypeError):
        state._reader.split_block(bytearray(data), True)      # (only bytes: held as they are)


# ---------------------------------------------------------------- analyse over Lines
def _odd_copy(tmp_path, name, every, crlf):
    """A sample with a non-ASCII comment line every `every` lines (a Lines that is not all
    ASCII: its ASCII lines still read in C, the others by Python) and "\\r\\n" endings."""
    with open(SAMPLES + name, "rb") as fh:
        lines = fh.read().split(b"\n")
    out = []
    for k, line in enumerate(lines):
        if k % every == every - 1:
            out.append("; caf\u00e9 \u20ac".encode())
        out.append(line)
    path = str(tmp_path / name.replace("/", "_"))
    with open(path, "wb") as fh:
        fh.write((b"\r\n" if crlf else b"\n").join(out))
    return path


@pytest.mark.skipif(not COMPILED, reason="the compiled model and reader are not built")
@pytest.mark.parametrize("every,crlf,hint,least_r", [(97, False, 1 << 16, 0.8), (5, True, 1 << 16, 0.6),
                                                     (300, False, 999, 0.8), (10 ** 9, True, 4096, 0.8)])
def test_analyse_over_lines_is_the_reference(tmp_path, monkeypatch, every, crlf, hint, least_r):
    """least_r: the share of the lines the C loops read at least (a non-ASCII line every 5
    lines breaks the runs: Python reads those lines and the ones that restart a run)."""
    path = _odd_copy(tmp_path, "prusa_gyroid.gcode", every, crlf)
    monkeypatch.setattr(fwsim, "CHUNK_HINT", hint)       # (line_chunks' bytes a block)
    chunks = list(state.line_chunks(path))
    assert all(type(lines) is state._reader.Lines for _, lines in chunks)
    n_lines = sum(len(lines) for _, lines in chunks)
    taken = _Taken(monkeypatch)
    _same(path, "prusa-mk3s")
    assert taken.run + taken.gap > least_r * n_lines, (taken.run, taken.gap, n_lines)


@pytest.mark.skipif(not COMPILED, reason="the compiled model and reader are not built")
def test_analyse_over_lists_is_the_reference(tmp_path, monkeypatch):
    """run_lines and gap_lines still read a list of str (read_chunks' chunks) in C."""
    path = _odd_copy(tmp_path, "prusa_gyroid.gcode", 97, False)

    def line_chunks(path, progress=None, cr=None):
        if cr is not None:
            cr[0] = True
        return fwsim.read_chunks(path, progress)
    monkeypatch.setattr(pl.reader, "line_chunks", line_chunks)
    taken = _Taken(monkeypatch)
    _same(path, "prusa-mk3s")
    assert taken.run + taken.gap > 0.8 * sum(1 for _ in open(path, "rb"))


# ---------------------------------------------------------------- the Limits a block reads
@pytest.mark.skipif(fwsim._core is None, reason="the compiled firmware-model core is not built")
@pytest.mark.parametrize("law", ["prusa-mk3s", "generic-marlin", "voron24"])
def test_blocks_read_each_limits_own_values(law):
    """sim_block keeps v_max and the junction's values (scv and mcr, or jd) for the Limits
    it last read: moves that go back and forth between shared Limits objects of other
    values, and a slot the model does not read holding no number, play as in Python."""
    from gcode_opt.profile import load_profile
    from test_fwcore_bits import _lim, _move, _play
    a = _lim(v_max=120.0, scv=3.0, mcr=0.2, jd=0.01)
    b = _lim(v_max=40.0, scv=9.0, mcr=0.7, jd=0.08)
    odd = _lim(v_max=60.0, **({"jd": "no"} if law == "voron24" else {"scv": None, "mcr": None}))
    lims = [a, a, b, a, b, b, odd, a, odd]
    moves = [_move(i, 7.0 * i, 3.0 * (i % 2), 7.0 * i + 7.0, 3.0 * ((i + 1) % 2), v=100.0, lim=lim)
             for i, lim in enumerate(lims)]
    prof = load_profile(law)
    py = _play("python", prof, moves)
    assert len(py[0]) > 0                       # (played, not an error)
    assert repr(_play("c", prof, moves)) == repr(py)


@pytest.mark.skipif(fwsim._core is None, reason="the compiled firmware-model core is not built")
@pytest.mark.parametrize("law,slot", [("prusa-mk3s", "v_max"), ("generic-marlin", "v_max"), ("voron24", "scv"),
                                      ("voron24", "mcr")])
def test_blocks_raise_where_python_reads_a_bad_limit(law, slot):
    """A slot the model reads that is no number: the same error, from the same move."""
    from gcode_opt.profile import load_profile
    from test_fwcore_bits import _lim, _move, _play
    bad = _lim(**{slot: "x"})
    moves = [_move(0, 0, 0, 10, 0), _move(1, 10, 0, 20, 5), _move(2, 20, 5, 30, 0, lim=bad)]
    py = _play("python", load_profile(law), moves)
    assert py[0] == "TypeError"
    assert repr(_play("c", load_profile(law), moves)) == repr(py)


# ---------------------------------------------------------------- M204 floats made when needed
@pytest.mark.skipif(not COMPILED, reason="the compiled model and reader are not built")
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24", "generic-marlin"])
def test_analyse_of_a_written_file_is_the_reference(tmp_path, prof):
    """A live session keeps an M204's values as doubles and makes their float only where a
    Move (run_lines' peek) or the state needs it, one for the slots Python gives one object:
    analyse of a re-timed file (an M204 before most segments, read by gap_lines between
    runs and peeked by run_lines after them) is the reference's, field by field."""
    from gcode_opt.pipeline import Options, process
    from gcode_opt.profile import load_profile
    path = str(tmp_path / "out.gcode")
    process(SAMPLES + "prusa_gyroid.gcode", path, load_profile(prof), Options())
    with open(path) as fh:
        assert sum(1 for raw in fh if raw.startswith("M204 ")) > 500
    _same(path, prof)
