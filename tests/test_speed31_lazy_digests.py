"""Session 31: the first rewrite pass no longer hashes its blocks as it writes them; a
second pass reads them back from the first's file (pipeline.block_digests).

- block_digests on a written file equals, digest by digest and in which strokes have one,
  the Digests rewrite fills as it writes (the compiled and the text rewrite; the
  compiled and the text reading back), on LF and CRLF inputs.
- A run that takes a second pass writes the same file and the same summary with the
  digests read back (LAZY_DIGESTS) as with the first pass's own (the code before)."""
from __future__ import annotations

import json
import os

import pytest

from gcode_opt import emit as emit_mod
from gcode_opt import pipeline as pl
from gcode_opt.outranges import Digests
from gcode_opt.profile import load_profile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = os.path.join(ROOT, "sample_gcode")


def _digest_bits(d):
    return bytes(d._d), bytes(d._has)


def _written(src, tmp_path, monkeypatch, prof):
    """Process src; the first rewrite's Digests (made as it writes), its out_ranges, the
    number of strokes and a copy of the file it wrote."""
    orig = pl.rewrite
    got = {}

    def spy(path, out_fh, strokes, plan, profile, opts, digests=None, reuse=None):
        if "digests" in got:
            return orig(path, out_fh, strokes, plan, profile, opts, digests, reuse)
        d = Digests(len(strokes))
        out_ranges = orig(path, out_fh, strokes, plan, profile, opts, d, reuse)
        out_fh.flush()
        with open(out_fh.name, "rb") as fh:
            got["bytes"] = fh.read()
        got.update(digests=d, out_ranges=list(out_ranges), n=len(strokes))
        return out_ranges

    monkeypatch.setattr(pl, "rewrite", spy)
    pl.process(src, str(tmp_path / "out.gcode"), load_profile(prof), pl.Options())
    monkeypatch.setattr(pl, "rewrite", orig)
    path = str(tmp_path / "first.gcode")
    with open(path, "wb") as fh:
        fh.write(got["bytes"])
    return got["digests"], got["out_ranges"], got["n"], path


@pytest.mark.parametrize("name,prof,crlf", [("prusa_gyroid", "prusa-mk3s", False),
                                            ("prusa_gyroid_arcs", "voron24", False),
                                            ("prusa_absolute_e", "prusa-mk3s", True)])
@pytest.mark.parametrize("text_rewrite", [False, True])
def test_block_digests_are_rewrites(tmp_path, monkeypatch, name, prof, crlf, text_rewrite):
    src = os.path.join(SAMPLES, name + ".gcode")
    if crlf:
        with open(src, "rb") as fh:
            data = fh.read().replace(b"\n", b"\r\n")
        src = str(tmp_path / "crlf.gcode")
        with open(src, "wb") as fh:
            fh.write(data)
    if text_rewrite:
        monkeypatch.setattr(emit_mod, "CORE_MOD", None)
    ref, out_ranges, n, path = _written(src, tmp_path, monkeypatch, prof)
    assert len(ref) > 50 and len(ref) == len(out_ranges)
    assert _digest_bits(pl.block_digests(path, out_ranges, n)) == _digest_bits(ref)
    monkeypatch.setattr(emit_mod, "CORE_MOD", None)          # the text reading back
    assert _digest_bits(pl.block_digests(path, out_ranges, n)) == _digest_bits(ref)


def test_block_digests_see_a_changed_block(tmp_path, monkeypatch):
    """One byte changed inside one block changes that block's digest only."""
    src = os.path.join(SAMPLES, "prusa_gyroid.gcode")
    ref, out_ranges, n, path = _written(src, tmp_path, monkeypatch, "prusa-mk3s")
    with open(path, "rb") as fh:
        lines = fh.readlines()
    a, z, i = out_ranges[len(out_ranges) // 2]
    lines[a + 1] = lines[a + 1][:-1] + b" \n"          # (a space more: one byte)
    with open(path, "wb") as fh:
        fh.writelines(lines)
    got = pl.block_digests(path, out_ranges, n)
    differ = got.differ(ref)
    assert differ.sum() == 1 and differ[i]


def _run(src, out, prof):
    s = pl.process(src, out, load_profile(prof), pl.Options())
    for k in ("timing_s", "elapsed_s", "output"):
        s.pop(k, None)
    with open(out, "rb") as fh:
        return fh.read(), json.dumps(s, sort_keys=True, default=str), s["rewrite_passes"]


@pytest.mark.parametrize("name,prof", [("prusa_gyroid_fullspeed", "voron24"), ("prusa_benchy_like", "prusa-mk3s")])
def test_second_pass_same_output(tmp_path, monkeypatch, name, prof):
    src = os.path.join(SAMPLES, name + ".gcode")
    calls = []
    orig = pl.block_digests

    def counting(*a):
        calls.append(a[0])
        return orig(*a)
    monkeypatch.setattr(pl, "block_digests", counting)
    lazy = _run(src, str(tmp_path / "lazy.gcode"), prof)
    assert lazy[2] == 2 and len(calls) == 1       # a second pass, the first's digests read back once
    monkeypatch.setattr(pl, "LAZY_DIGESTS", False)
    eager = _run(src, str(tmp_path / "eager.gcode"), prof)
    assert len(calls) == 1
    assert lazy == eager
