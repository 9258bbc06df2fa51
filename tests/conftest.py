"""Shared test helpers."""
from gcode_opt.pipeline import Options, process
from gcode_opt.profile import load_profile

SAMPLES = "sample_gcode/"

# The ringing's core steps from the first event (a run's first resonance.PROBE_AFTER events
# go by numpy): the tests that compare them with numpy's then compare the core's.
from gcode_opt.firmware import resonance as _resonance  # noqa: E402
_resonance.PROBE_AFTER = 0


def process_cases(tmp_dir, cases):
    """Process each (sample name, profile, features) case into tmp_dir: {case: (output path, summary)}."""
    out = {}
    for name, prof, feats in cases:
        dst = str(tmp_dir / f"{prof}-{len(feats)}-{name}")
        out[(name, prof, feats)] = (dst, process(SAMPLES + name, dst, load_profile(prof), Options(features=feats)))
    return out


# ---------------------------------------------------------------- the firmware model's two cores
# The firmware model's own tests run on both cores: the compiled one (firmware/_core.c,
# skipped where it is not built) and the pure-Python one, which every install keeps.
import pytest  # noqa: E402

from gcode_opt.firmware import simulate as _fw_sim  # noqa: E402

FW_CORE_MODULES = {"test_firmware", "test_klipper_oracle"}


def pytest_generate_tests(metafunc):
    if metafunc.module.__name__.rsplit(".", 1)[-1] in FW_CORE_MODULES:
        metafunc.fixturenames.append("fw_core")
        metafunc.parametrize("fw_core", ["c", "python"], indirect=True)


@pytest.fixture
def fw_core(request):
    """Plays the firmware model on request.param ("c" or "python") for one test."""
    if request.param == "c" and _fw_sim._core is None:
        pytest.skip("the compiled firmware-model core is not built here (pip install . with a C compiler)")
    old = _fw_sim.use_core(request.param)
    yield request.param
    _fw_sim.use_core(old)


# ---------------------------------------------------------------- the reader's two paths
# The reader's own tests run on both: the compiled fast path (_reader.c, skipped where it
# is not built) with Python behind it, and the pure-Python step.
from gcode_opt import state as _state  # noqa: E402

READER_MODULES = {"test_state", "test_words_strict", "test_no_comments"}
READER_FUNCTIONS = {"test_reader_m204_fast_path_is_the_strict_reading",       # test_speed_paths
                    "test_reader_snapshot_restores_everything_a_line_changes"}
_fw_generate_tests = pytest_generate_tests


def pytest_generate_tests(metafunc):  # noqa: F811 -- extends the firmware model's hook above
    _fw_generate_tests(metafunc)
    if (metafunc.module.__name__.rsplit(".", 1)[-1] in READER_MODULES
            or metafunc.function.__name__ in READER_FUNCTIONS):
        metafunc.fixturenames.append("reader")
        metafunc.parametrize("reader", ["c", "python"], indirect=True)


@pytest.fixture
def reader(request):
    """Reads with request.param ("c" or "python") for one test."""
    if request.param == "c" and _state._C_STEP is None:
        pytest.skip(f"the compiled reader is not used here ({_state.CORE_WHY})")
    old = _state.use_reader(request.param)
    yield request.param
    _state.use_reader(old)
