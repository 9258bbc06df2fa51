"""benchmarks/bench_command.py runs the real command on a bundled sample and reports it."""
import os
import re
from bench_modules import load_bench

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..")


def _load():
    return load_bench("bench_command")


def test_one_round_on_the_small_sample(tmp_path, capsys):
    mod = _load()
    mod.main([f"{ROOT}:this", "--rounds", "1", "--files", "small", "--tmp", str(tmp_path / "new")])
    out = capsys.readouterr().out
    row = re.search(r"^\s+0 small\s+this\s+([\d.]+)\s+(\d+)\s+([\d.]+)\s+([\d.]+)$", out, re.M)
    assert row, out                       # no "exit N": the command succeeded
    cpu, rss = float(row.group(1)), float(row.group(4))
    assert cpu > 0.05 and rss > 20.0      # a real run: interpreter, numpy, the file
    # the command wrote the file it was asked for, a processed one
    written = (tmp_path / "new" / "small_this.gcode").read_text(errors="replace")
    assert "gcode-opt" in written
    assert "small       this       CPU" in out


def test_unknown_file_name_is_refused(capsys):
    mod = _load()
    try:
        mod.main(["--files", "nosuch"])
    except SystemExit as e:
        assert e.code == 2
    else:
        raise AssertionError("accepted an unknown file name")
    assert "unknown file 'nosuch'" in capsys.readouterr().err


def test_a_folder_that_is_not_a_tree_is_refused(tmp_path, capsys):
    # run from inside another checkout, `python -m gcode_opt` would import that one: each
    # tree must import its own package
    mod = _load()
    try:
        mod.main([f"{tmp_path}:empty", "--rounds", "1", "--files", "small", "--tmp", str(tmp_path / "out")])
    except SystemExit as e:
        assert "not its own tree" in str(e.code)
    else:
        raise AssertionError("ran a folder with no gcode_opt in it")
