"""Shared test helpers."""
from gcode_opt.pipeline import Options, process
from gcode_opt.profile import load_profile

SAMPLES = "sample_gcode/"


def process_cases(tmp_dir, cases):
    """Process each (sample name, profile, features) case into tmp_dir: {case: (output path, summary)}."""
    out = {}
    for name, prof, feats in cases:
        dst = str(tmp_dir / f"{prof}-{len(feats)}-{name}")
        out[(name, prof, feats)] = (dst, process(SAMPLES + name, dst, load_profile(prof), Options(features=feats)))
    return out
