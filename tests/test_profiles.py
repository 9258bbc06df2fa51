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
                 'junction_deviation_d = 0.02\n'
                 '[limits]\nmax_velocity_v = 250.0\nmax_accel_a = 2500.0\n'
                 '[machine]\nmoving_mass_x_kg = 0.3\n')
    p = load_profile(str(f))
    assert p.name == "my-printer"
    assert (p.flavour, p.junction) == ("marlin2", "jd")
    assert (p.max_velocity_v, p.max_accel_a, p.moving_mass_x_kg) == (250.0, 2500.0, 0.3)
    assert p.sources == ("test",)


def test_bad_flavour_and_unknown_name_rejected(tmp_path):
    f = tmp_path / "x.toml"
    f.write_text('[firmware]\nflavour = "smoothie"\n')
    with pytest.raises(ValueError, match="flavour"):
        load_profile(str(f))
    with pytest.raises(ValueError, match="no profile named"):
        load_profile("no-such-printer")


# ---------------------------------------------------------------- schema (issue 7 item 4)
GOOD = {"firmware": {"flavour": "klipper", "junction": "scv", "square_corner_velocity_v": 5.0},
        "limits": {"max_velocity_v": 300.0, "max_accel_a": 3000.0}}


def _toml(d):
    """A small TOML writer for the cases below (values given as TOML text)."""
    out = []
    for k, v in d.items():
        if not isinstance(v, dict):
            out.append(f"{k} = {v}")
    for k, v in d.items():
        if isinstance(v, dict):
            out.append(f"[{k}]")
            out += [f"{kk} = {vv}" for kk, vv in v.items()]
    return "\n".join(out) + "\n"


def _good_text(**over):
    d = {"firmware": {"flavour": '"klipper"', "junction": '"scv"', "square_corner_velocity_v": "5.0"},
         "limits": {"max_velocity_v": "300.0", "max_accel_a": "3000.0"}}
    for key, (table, val) in over.items():
        if val is None:
            d[table].pop(key, None)
        else:
            d.setdefault(table, {})[key] = val
    return _toml(d)


def _load_text(tmp_path, text, name="my.toml"):
    f = tmp_path / name
    f.write_text(text)
    return load_profile(str(f)), str(f)


def test_minimal_profile_loads_with_stated_defaults(tmp_path):
    p, _ = _load_text(tmp_path, _good_text())
    assert (p.flavour, p.junction, p.max_velocity_v, p.max_accel_a) == ("klipper", "scv", 300.0, 3000.0)
    # documented derived defaults: accelerations in force start at the machine's maximum
    assert p.default_accel_a == p.travel_accel_a == p.retract_accel_a == 3000.0
    p, _ = _load_text(tmp_path, _good_text(default_accel_a=("limits", "1500")))
    assert p.default_accel_a == p.travel_accel_a == p.retract_accel_a == 1500.0
    assert isinstance(p.max_velocity_v, float)


@pytest.mark.parametrize("key,table,val,why", [
    ("max_accel_a", "limits", "-1000", "max_accel_a = -1000: must be > 0 mm/s^2"),
    ("max_accel_a", "limits", "0", "max_accel_a = 0: must be > 0 mm/s^2"),
    ("max_accel_a", "limits", "true", "max_accel_a = true: must be a number in mm/s^2, not true/false"),
    ("max_accel_a", "limits", '"fast"', 'max_accel_a = "fast": must be a number in mm/s^2, not a string'),
    ("max_accel_a", "limits", "inf", "max_accel_a = inf: must be a finite number"),
    ("default_accel_a", "limits", "nan", "default_accel_a = nan: must be a finite number"),
    ("max_velocity_v", "limits", "0", "max_velocity_v = 0: must be > 0 mm/s"),
    ("moving_mass_x_kg", "machine", "0", "moving_mass_x_kg = 0: must be > 0 kg"),
    ("moving_mass_y_kg", "machine", "-0.5", "moving_mass_y_kg = -0.5: must be > 0 kg"),
    ("minimum_cruise_ratio_r", "firmware", "1.0", "minimum_cruise_ratio_r = 1.0: must be in [0, 1)"),
    ("minimum_cruise_ratio_r", "firmware", "-0.1", "minimum_cruise_ratio_r = -0.1: must be in [0, 1)"),
    ("block_buffer", "firmware", "-1", "block_buffer = -1: must be in [0, 100000] moves"),
    ("block_buffer", "firmware", "16.5", "block_buffer = 16.5: must be a whole number"),
    ("block_buffer", "firmware", "true", "block_buffer = true: must be a number in moves, not true/false"),
    ("arc_segment_d", "firmware", "1e-9", "arc_segment_d = 1e-09: must be in [0.01, 10] mm"),
    ("arc_segment_d", "firmware", "50", "arc_segment_d = 50: must be in [0.01, 10] mm"),
    ("max_segment_rate", "firmware", "0", "max_segment_rate = 0: must be > 0 segments/s"),
    ("flavour", "firmware", '"smoothie"', 'flavour = "smoothie": must be one of klipper, marlin2, marlin-legacy, rrf'),
    ("junction", "firmware", "1", "junction = 1: must be one of scv, jd, jerk"),
    ("filament_diameter_d", "machine", "0", "filament_diameter_d = 0: must be in [0.1, 10] mm"),
    ("max_accel_a", "limits", "1e300", "max_accel_a = 1e+300: must be <= 1e+06 mm/s^2 (far above any printer: a typo?)"),
    ("max_velocity_v", "limits", "3e5", "max_velocity_v = 300000.0: must be <= 10000 mm/s (far above any printer: a typo?)"),
])
def test_bad_value_names_file_and_key(tmp_path, key, table, val, why):
    with pytest.raises(ValueError) as ei:
        _load_text(tmp_path, _good_text(**{key: (table, val)}))
    assert str(ei.value) == f"{tmp_path / 'my.toml'}: {why}"


@pytest.mark.parametrize("drop", ["flavour", "junction", "square_corner_velocity_v"])
def test_required_firmware_keys(tmp_path, drop):
    with pytest.raises(ValueError, match=f"my.toml: missing .*{drop} \\(under \\[firmware\\]\\)"):
        _load_text(tmp_path, _good_text(**{drop: ("firmware", None)}))


@pytest.mark.parametrize("drop", ["max_velocity_v", "max_accel_a"])
def test_required_limits(tmp_path, drop):
    with pytest.raises(ValueError, match=f"missing {drop} \\(under \\[limits\\]\\)"):
        _load_text(tmp_path, _good_text(**{drop: ("limits", None)}))


def test_junction_model_needs_its_parameter(tmp_path):
    text = _good_text(junction=("firmware", '"jd"'))
    with pytest.raises(ValueError, match="missing junction_deviation_d"):
        _load_text(tmp_path, text)
    p, _ = _load_text(tmp_path, _good_text(junction=("firmware", '"jerk"'), jerk_xy_v=("firmware", "8")))
    assert p.jerk_xy_v == 8.0


def test_no_flavour_is_not_klipper(tmp_path):
    """A profile without flavour used to become Klipper silently."""
    with pytest.raises(ValueError, match="missing flavour"):
        _load_text(tmp_path, _good_text(flavour=("firmware", None)))


@pytest.mark.parametrize("text,why", [
    ("", "empty profile"),
    ("# only a comment\n", "empty profile"),
    ('max_accel_a = 3000\n', "max_accel_a belongs under [limits], not at the top"),
    ('[firmware]\nmax_velocity_v = 300\n', "max_velocity_v belongs under [limits], not under [firmware]"),
    ('[machine]\nflavour = "klipper"\n', "flavour belongs under [firmware], not under [machine]"),
    ('[limits]\nname = "x"\n', "name belongs at the top of the file, not under [limits]"),
    ('[printer]\nmax_velocity = 3\n', "unknown table [printer]"),
    ('[limits]\nmax_warp_speed = 9\n', "unknown key max_warp_speed in [limits]"),
    ('limits = 3\n', "limits must be a table"),
    ('[limits\n', "my.toml:1: not valid TOML"),
])
def test_structure_errors(tmp_path, text, why):
    with pytest.raises(ValueError) as ei:
        _load_text(tmp_path, text)
    assert why in str(ei.value) and str(ei.value).startswith(str(tmp_path / "my.toml"))


def test_missing_or_odd_profile_files(tmp_path):
    with pytest.raises(ValueError, match="nosuch.toml: no such profile file; bundled profiles: .*prusa-mk3s"):
        load_profile(str(tmp_path / "nosuch.toml"))
    with pytest.raises(ValueError, match="is a directory"):
        load_profile(str(tmp_path) + "/")
    bad = tmp_path / "bin.toml"
    bad.write_bytes(b"\xff\xfe\x00junk")
    with pytest.raises(ValueError, match="bin.toml: not a text"):
        load_profile(str(bad))


def test_every_schema_key_is_a_profile_field():
    from gcode_opt.profile import SCHEMA
    assert set(SCHEMA) | {"name"} == {f.name for f in dataclasses.fields(Profile)}


@pytest.mark.parametrize("name", _bundled())
def test_bundled_profile_keys_in_their_tables(name):
    """Bundled files follow the schema's tables (the loader would refuse them otherwise,
    checked independently here from the raw TOML)."""
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - 3.10
        import tomli as tomllib
    data = tomllib.loads((PROFILES_DIR / f"{name}.toml").read_text())
    assert set(data) <= {"name", "sources", "firmware", "limits", "machine", "resonance"}
    assert {"flavour", "junction"} <= set(data["firmware"])
    assert {"max_velocity_v", "max_accel_a"} <= set(data["limits"])
