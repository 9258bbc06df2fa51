"""The strokes of a pipeline.process run, for tests whose reference reads stroke objects:
since session 50 the steps after planning (stroke_lines, build_summary) are handed the
strokes' StrokeColumns, not the list."""
import contextlib


@contextlib.contextmanager
def _strokes_kept():
    """Within: pipeline.analyse's strokes put in the list yielded (one list a run)."""
    from gcode_opt import pipeline
    kept, real = [], pipeline.analyse

    def spy(*a, **k):
        got = real(*a, **k)
        kept.append(got[0])
        return got
    pipeline.analyse = spy
    try:
        yield kept
    finally:
        pipeline.analyse = real
