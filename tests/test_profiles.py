"""Bundled printer profiles: they load, their numbers are physically sane, each number is
annotated, and the loader rejects unknown keys and accepts a path."""
import dataclasses
import re
from pathlib import Path

import pytest

from gcode_opt.profile import FLAVOURS, JUNCTION_MODELS, Profile, load_profile, profile_names

PROFILES_DIR = Path(__file__).resolve().parent.parent / "profiles"
REQUIRED = {"generic-klipper", "generic-marlin", "prusa-mk3s", "prusa-mk4",
            "ender3", "voron24", "bambu-x1c"}


def _bundled():
    return sorted(p.stem for p in PROFILES_DIR.glob("*.toml"))


def test_required_profiles_present():
    names = set(profile_names())
    assert REQUIRED <= names, f"missing: {sorted(REQUIRED - names)}"
    assert REQUIRED <= set(_bundled())


@pytest.mark.parametrize("name", _bundled())
def test_profile_loads_and_is_sane(name):
    p = load_profile(name)
    assert isinstance(p, Profile)
    assert p.name == name
    assert p.flavour in FLAVOURS
    assert p.junction in JUNCTION_MODELS
    for a in (p.max_accel_a, p.default_accel_a, p.travel_accel_a, p.retract_accel_a):
        assert 100 <= a <= 50000
    assert 20 <= p.max_velocity_v <= 1500
    assert 0.05 <= p.moving_mass_x_kg <= 5
    assert 0.05 <= p.moving_mass_y_kg <= 5
    assert 1 <= p.max_z_velocity_v <= 100
    assert 10 <= p.max_z_accel_a <= 5000
    assert 5 <= p.max_e_velocity_v <= 300
    assert 0 < p.square_corner_velocity_v <= 50
    assert 0 <= p.minimum_cruise_ratio_r < 1
    assert 0 < p.junction_deviation_d <= 0.5
    assert 0 < p.jerk_xy_v <= 50
    assert p.block_buffer >= 0 and isinstance(p.block_buffer, int)
    assert 0 <= p.min_segment_time_t <= 0.1
    assert 10 <= p.max_segment_rate <= 100000
    assert 0.01 <= p.arc_segment_d <= 5
    assert p.filament_diameter_d in (1.75, 2.85)
    assert 1 <= p.max_volumetric_flow <= 100
    assert 0 <= p.fw_retract_length_d <= 10
    assert 1 <= p.fw_retract_speed_v <= 200
    # the model each flavour is expected to use
    if p.flavour == "klipper":
        assert p.junction == "scv" and p.block_buffer == 0
    else:
        assert p.junction in ("jd", "jerk") and p.block_buffer > 0


@pytest.mark.parametrize("name", _bundled())
def test_profile_has_sources(name):
    p = load_profile(name)
    assert isinstance(p.sources, tuple) and len(p.sources) > 0
    assert all(isinstance(s, str) and s.strip() for s in p.sources)


_NUMBER_LINE = re.compile(r"^\s*[A-Za-z_][A-Za-z0-9_]*\s*=\s*[-+]?[0-9]")


@pytest.mark.parametrize("name", _bundled())
def test_every_number_is_annotated(name):
    """Each `key = <number>` line says where the number comes from (a trailing comment)."""
    for i, line in enumerate((PROFILES_DIR / f"{name}.toml").read_text().splitlines(), 1):
        if _NUMBER_LINE.match(line):
            assert "#" in line and line.split("#", 1)[1].strip(), f"{name}.toml:{i} has no comment"


@pytest.mark.parametrize("name", _bundled())
def test_profile_sets_every_field(name):
    """Bundled profiles don't lean on the dataclass defaults silently."""
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - 3.10
        import tomli as tomllib
    data = tomllib.loads((PROFILES_DIR / f"{name}.toml").read_text())
    flat = {}
    for k, v in data.items():
        flat.update(v if isinstance(v, dict) else {k: v})
    missing = {f.name for f in dataclasses.fields(Profile)} - set(flat)
    assert not missing, f"{name}.toml leaves {sorted(missing)} at the code default"


def test_unknown_key_raises_naming_the_key(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text('name = "bad"\n[limits]\nmax_velocity_v = 200.0\nmax_warp_speed = 9.0\n')
    with pytest.raises(ValueError, match="max_warp_speed"):
        load_profile(str(f))


def test_load_by_path(tmp_path):
    f = tmp_path / "my-printer.toml"
    f.write_text('sources = ["test"]\n[firmware]\nflavour = "marlin2"\njunction = "jd"\n'
                 '[limits]\nmax_velocity_v = 250.0\nmax_accel_a = 2500.0\n'
                 '[machine]\nmoving_mass_x_kg = 0.3\n')
    p = load_profile(str(f))
    assert p.name == "my-printer"
    assert (p.flavour, p.junction) == ("marlin2", "jd")
    assert (p.max_velocity_v, p.max_accel_a, p.moving_mass_x_kg) == (250.0, 2500.0, 0.3)
    assert p.sources == ("test",)


def test_bad_flavour_and_unknown_name_rejected(tmp_path):
    f = tmp_path / "x.toml"
    f.write_text('flavour = "smoothie"\n')
    with pytest.raises(ValueError, match="flavour"):
        load_profile(str(f))
    with pytest.raises(ValueError, match="no profile named"):
        load_profile("no-such-printer")
