"""Session 49: what a process run does not import at its start -- argparse (and gettext,
locale through it: a plain command line, cli._plain_process), tomllib (a bundled profile,
profile._plain_toml), string (words spells ascii_letters out), signal (outfile calls the C
module _signal) -- in a fresh interpreter; and the rare paths that need them still work:
argparse's messages, a user's profile file, the interrupt message that names the signal."""
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SAMPLE = str(ROOT / "sample_gcode" / "prusa_mk3s_rectilinear.gcode")
DEFERRED = ("argparse", "gettext", "locale", "tomllib", "string", "signal")


def _run(code):
    got = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert got.returncode == 0, got.stderr[-2000:]
    return got.stdout.split()


def test_a_process_run_imports_none_of_them(tmp_path):
    out = str(tmp_path / "out.gcode")
    code = ("import sys; from gcode_opt.cli import main; "
            f"rc = main(['process', {SAMPLE!r}, '-o', {out!r}, '-q', '--profile', 'prusa-mk3s', '--segments', '8']); "
            f"print(rc, *[m for m in {DEFERRED!r} if m in sys.modules])")
    assert _run(code) == ["0"]


def test_the_rare_paths_that_need_them(tmp_path):
    src = (ROOT / "profiles" / "prusa-mk3s.toml").read_text()
    (tmp_path / "mine.toml").write_text(src)
    out = str(tmp_path / "out.gcode")
    code = ("import contextlib, io, sys; from gcode_opt.cli import main; err = io.StringIO()\n"
            "with contextlib.redirect_stderr(err):\n"
            f"    rc = main(['process', {SAMPLE!r}, '-o', {out!r}, '-q', '--profile', {str(tmp_path / 'mine.toml')!r}])\n"
            "    try:\n"
            f"        main(['process', {SAMPLE!r}, '--segments', '0'])\n"
            "    except SystemExit as e:\n"
            "        rc2 = e.code\n"
            "print(rc, rc2, 'tomllib' in sys.modules, 'argparse' in sys.modules, "
            "'--segments: 0: must be >= 1' in err.getvalue())")
    assert _run(code) == ["0", "2", "True", "True", "True"]


def test_the_interrupt_message_names_the_signal(monkeypatch, capsys):
    """(cli imports signal for the name: Interrupted carries the number)"""
    from gcode_opt import cli, outfile

    def interrupted(a):
        raise outfile.Interrupted(15)
    monkeypatch.setattr(cli, "cmd_process", interrupted)
    assert cli.main(["process", "x.gcode", "-q"]) == 143
    assert "gcode-opt: interrupted by SIGTERM; x.gcode left unchanged" in capsys.readouterr().err


def test_words_letters_are_ascii_letters():
    import string
    from gcode_opt import words
    assert words._LETTERS == frozenset(string.ascii_letters)
