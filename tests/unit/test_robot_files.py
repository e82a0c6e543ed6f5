"""Robot description files: the shipped default, keys, overrides, the code table and the link."""
from __future__ import annotations

import json
import math
import tomllib

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bhr.model._codes import CODE_AXIS, VALID_CODES
from bhr.model._robot import Robot
from bhr.model._robotfile import (
    LINK_KEYS,
    ROBOT_KEYS,
    LinkSettings,
    code_table,
    default_robot_file,
    load_robot_file,
)
from bhr._settings.errors import BhrError

FAST = settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def write(path, text):
    path.write_text(text, encoding="utf-8")
    return path


def test_default_file_is_the_thesis_robot():
    rf = load_robot_file(default_robot_file())
    assert rf.robot == Robot()
    assert rf.name == "thesis" and rf.path == default_robot_file()
    assert rf.link == LinkSettings(port=None, baudrate=115200, module_order=(1, 2, 3, 4, 5), on_max_ms=5000,
                                   cooldown_ms=10000, silence_ms=1000)
    assert rf.codes == {0: "rest", 3: "+x", 6: "+y", 12: "-x", 9: "-y", 15: "lift"}
    # the file documents every key it may hold
    data = tomllib.loads(default_robot_file().read_text())
    text = default_robot_file().read_text()
    for key in ROBOT_KEYS:
        assert key in data or f"# {key} =" in text
    assert set(data["link"]) | {"module_order"} == set(LINK_KEYS) and "# module_order = [1, 2, 3, 4, 5]" in text


def test_a_copy_of_the_default_file_with_other_modules_loads(tmp_path):
    """docs/robot-files.md says: copy the default file and edit it. A copy with `modules = 7` was refused by every
    command (its [link] listed the module order of 5 modules) until that line was edited too."""
    text = default_robot_file().read_text()
    assert "\nmodules = 5 " in text
    rf = load_robot_file(write(tmp_path / "my-robot.toml", text.replace("\nmodules = 5 ", "\nmodules = 7 ")))
    assert rf.robot.modules == 7 and rf.link.module_order == (1, 2, 3, 4, 5, 6, 7)


def test_code_table_is_the_one_in_bhr_codes():
    table = code_table()
    assert sorted(table) == sorted(VALID_CODES)
    for code, (axis, sign) in CODE_AXIS.items():
        assert table[code] == ("+" if sign > 0 else "-") + "xy"[axis]


def test_an_empty_file_gives_robot_defaults(tmp_path):
    rf = load_robot_file(write(tmp_path / "empty.toml", ""))
    assert rf.robot == Robot() and rf.name == "empty" and rf.link.module_order == (1, 2, 3, 4, 5)


def test_values_and_stroke_lever(tmp_path):
    f = write(tmp_path / "r.toml", "modules = 7\nmodule_length = 12.5\nstroke = 2.0\nlever = 8.0\ntol_pos = 3\n"
                                   "feed_divisor = 4\nweight_pos = 1\nweight_ori = 0\n[link]\nport = 'loop://'\n"
                                   "module_order = [7, 6, 5, 4, 3, 2, 1]\n")
    rf = load_robot_file(f)
    r = rf.robot
    assert (r.modules, r.module_length, r.tol_pos, r.feed_divisor, r.weight_pos, r.weight_ori) == (7, 12.5, 3, 4, 1, 0)
    assert r.alpha == pytest.approx(math.degrees(math.asin(2.0 / 8.0)))
    assert r.feed == 12.5 / 4
    assert rf.link.port == "loop://" and rf.link.modules == 7
    assert rf.link.to_chain([0, 3, 6, 9, 12, 15, 0]) == [0, 15, 12, 9, 6, 3, 0]
    assert rf.link.firmware_make_args()[0] == "MODULES=7"


@FAST
@given(order=st.permutations(list(range(1, 9))), codes=st.lists(st.sampled_from(VALID_CODES), min_size=8, max_size=8))
def test_chain_order_round_trip(order, codes):
    link = LinkSettings(module_order=tuple(order))
    chain = link.to_chain(codes)
    assert link.from_chain(chain) == codes
    assert all(chain[pos] == codes[m - 1] for pos, m in enumerate(order))


@pytest.mark.parametrize("text, message", [
    ("modlues = 5\n", "unknown key 'modlues'; did you mean 'modules'?"),
    ("colour = 'red'\n", "unknown key 'colour'"),
    ("modules = 0\n", "modules must be greater than 0"),
    ("modules = -3\n", "modules must be greater than 0"),
    ("modules = 2.5\n", "modules must be a whole number"),
    ("modules = 'five'\n", "modules must be a whole number, got the text 'five'"),
    ("modules = 5000\n", "modules must be at most 1000"),
    ("module_length = 0\n", "module_length must be greater than 0"),
    ("module_length = -10.0\n", "module_length must be greater than 0"),
    ("module_length = nan\n", "module_length must be a finite number"),
    ("module_length = inf\n", "module_length must be a finite number"),
    ("module_length = true\n", "module_length must be a number, got a boolean"),
    ("module_length = [10]\n", "module_length must be a number, got a list"),
    ("robot_radius = -1\n", "robot_radius must be greater than 0"),
    ("radius = 4\n", "unknown key 'radius'; did you mean 'robot_radius'"),
    ("alpha = 0\n", "outside (0, 90)"),
    ("alpha = 90\n", "outside (0, 90)"),
    ("alpha = 95.5\n", "outside (0, 90)"),
    ("alpha = -10\n", "outside (0, 90)"),
    ("alpha = nan\n", "alpha must be a finite number"),
    ("alpha = 10\nstroke = 1\nlever = 5\n", "not both"),
    ("stroke = 1\n", "lever is missing"),
    ("stroke = 6\nlever = 5\n", "must be shorter than lever"),
    ("tol_pos = 0\n", "tol_pos must be greater than 0"),
    ("tol_ori = 200\n", "tol_ori must be at most 180"),
    ("max_iter = 0\n", "max_iter must be greater than 0"),
    ("feed_divisor = 0\n", "feed_divisor must be greater than 0"),
    ("weight_pos = -0.5\n", "weight_pos must be 0 or more"),
    ("name = 5\n", "name must be text"),
    ("modules = 5\nmodules = 6\n", "not valid TOML"),
    ("modules = \n", "not valid TOML (Invalid value (at line 1"),
    ("[codes]\n0 = 'rest'\n3 = '+y'\n6 = '+x'\n12 = '-x'\n9 = '-y'\n15 = 'lift'\n", "code 3 is '+y' in this file"),
    ("[codes]\n0 = 'rest'\n3 = '+x'\n", "code 6 is missing"),
    ("[codes]\n5 = 'rest'\n", "5 is not a stable code"),
    ("[codes]\nthree = '+x'\n", "key 'three' is not a code number"),
    ("[codes]\n3 = 1\n", "must be text such as '+x'"),
    ("codes = 3\n", "codes must be a table"),
    ("[link]\nbaud = 9600\n", "unknown key 'baud'; did you mean 'baudrate'?"),
    ("[link]\nbaudrate = 0\n", "baudrate must be greater than 0"),
    ("[link]\nbaudrate = 10\n", "between 50 and 4000000"),
    ("[link]\nbaudrate = 'fast'\n", "baudrate must be a whole number"),
    ("[link]\nport = 3\n", "port must be text"),
    ("[link]\non_max_ms = 0\n", "on_max_ms must be greater than 0"),
    ("[link]\ncooldown_ms = 5\n", "between 10 and 60000"),
    ("[link]\nsilence_ms = 100000\n", "between 10 and 60000"),
    ("[link]\nsilence_ms = nan\n", "silence_ms must be a finite number"),
    ("[link]\nmodule_order = [1, 2, 2, 4, 5]\n", "module 2 appears twice"),
    ("[link]\nmodule_order = [1, 2, 3, 4, 6]\n", "there is no module 6"),
    ("[link]\nmodule_order = [1, 2, 3]\n", "lists 3 modules but the robot has 5"),
    ("[link]\nmodule_order = [1, 2, 3, 4, 0]\n", "must be greater than 0"),
    ("[link]\nmodule_order = 5\n", "must be a list of module numbers"),
    ("link = 'usb'\n", "link must be a table"),
    ("modules = 40\n[link]\nport = 'x'\n", "at most 32 modules"),
])
def test_bad_robot_files_get_one_line_naming_file_and_key(tmp_path, text, message):
    f = write(tmp_path / "robot.toml", text)
    with pytest.raises(BhrError) as exc:
        load_robot_file(f)
    msg = str(exc.value)
    assert message in msg, msg
    assert msg.startswith(str(f)) and "\n" not in msg


def test_missing_unreadable_and_wrong_kind_files(tmp_path):
    with pytest.raises(BhrError, match=r"no such robot file .*nope\.toml; give a robot description such as"):
        load_robot_file(tmp_path / "nope.toml")
    with pytest.raises(BhrError, match="is a folder"):
        load_robot_file(tmp_path)
    (tmp_path / "bin.toml").write_bytes(b"modules = 5\n\xff\xfe\n")
    with pytest.raises(BhrError, match=r"line 2: not UTF-8"):
        load_robot_file(tmp_path / "bin.toml")
    with pytest.raises(BhrError, match=r"robot files are TOML \(.toml\) or JSON \(.json\)"):
        load_robot_file(write(tmp_path / "robot.yaml", "modules: 5"))
    with pytest.raises(BhrError, match=r"not valid JSON \(line 1"):
        load_robot_file(write(tmp_path / "broken.json", "{modules = 5}"))
    with pytest.raises(BhrError, match=r"a JSON object .* got a list"):
        load_robot_file(write(tmp_path / "list.json", "[5]"))


def test_json_robot_file_is_read_as_the_toml_one(tmp_path):
    """The shipped default as JSON (same keys, same checks) gives the same robot, link and thermal model."""
    import json
    import tomllib

    table = tomllib.loads(default_robot_file().read_text())
    toml_rf = load_robot_file(default_robot_file())
    json_rf = load_robot_file(write(tmp_path / "robot.json", json.dumps(table)))
    assert json_rf.robot == toml_rf.robot and json_rf.link == toml_rf.link and json_rf.thermal == toml_rf.thermal
    table["alpha"] = 12.5
    table["robot_radius"] = 4.0
    rf = load_robot_file(write(tmp_path / "r2.json", json.dumps(table)))
    assert rf.robot.alpha == 12.5 and rf.robot.robot_radius == 4.0
    table["alphaa"] = 3
    with pytest.raises(BhrError, match=r"r3.json: unknown key 'alphaa'; did you mean 'alpha'\?"):
        load_robot_file(write(tmp_path / "r3.json", json.dumps(table)))


def test_a_runs_robot_is_reused_from_its_run_json(tmp_path):
    import json

    import bhr

    robot = bhr.Robot(modules=4, module_length=8.0, robot_radius=3.5, stroke=1.0, lever=6.0, tol_pos=5.0)
    run = bhr.follow(bhr.trajectory("line", length=30), robot=robot)
    rf = load_robot_file(write(tmp_path / "run.json", json.dumps(run.to_dict())))
    assert rf.robot == robot


def test_robot_file_keys_name_the_disc_radius_robot_radius_only(tmp_path):
    with pytest.raises(BhrError) as err:
        load_robot_file(write(tmp_path / "r.toml", "modules = 5\nbogus = 1\n"))
    allowed = str(err.value).split("allowed: ")[1]
    assert "robot_radius" in allowed and " radius," not in allowed
    assert load_robot_file(write(tmp_path / "r.toml", "robot_radius = 4.5\n")).robot.robot_radius == 4.5


values = st.one_of(st.integers(-10, 2000), st.floats(allow_nan=True, allow_infinity=True), st.booleans(),
                   st.text(max_size=5), st.just([1, 2]))


def toml_scalar(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else ("-inf" if v == -math.inf else repr(v)))
    if isinstance(v, str):
        return json.dumps(v)
    return str(v) if not isinstance(v, list) else "[" + ", ".join(map(str, v)) + "]"


@FAST
@given(data=st.dictionaries(st.sampled_from(list(ROBOT_KEYS) + ["bogus"]), values, max_size=5))
def test_any_robot_values_load_exactly_or_fail_in_one_line(tmp_path, data):
    f = write(tmp_path / "r.toml", "".join(f"{k} = {toml_scalar(v)}\n" for k, v in data.items()))
    try:
        rf = load_robot_file(f)
    except BhrError as exc:
        msg = str(exc)
        assert msg.startswith(str(f)) and "\n" not in msg
        return
    for key, v in data.items():
        if key in ("stroke", "lever"):
            continue
        assert getattr(rf.robot, key) == v
    assert 0 < rf.robot.alpha < 90 and rf.robot.modules >= 1


@FAST
@given(text=st.text(max_size=200))
def test_any_text_is_a_robot_or_one_clear_line(tmp_path, text):
    f = tmp_path / "r.toml"
    f.write_text(text, encoding="utf-8")
    try:
        load_robot_file(f)
    except BhrError as exc:
        assert str(exc).startswith(str(f)) and "\n" not in str(exc)


# --- on the command line ----------------------------------------------------------------------------------------


def test_the_disc_radius_has_one_name_robot_radius(tmp_path):
    """One name per setting: the Robot field, the robot-file key and the option are all robot_radius."""
    new = tmp_path / "new.toml"
    new.write_text("robot_radius = 7.5\n")
    assert load_robot_file(new).robot.robot_radius == 7.5 == Robot(robot_radius=7.5).robot_radius
    old = tmp_path / "old.toml"
    old.write_text("radius = 7.5\n")
    with pytest.raises(BhrError, match="unknown key 'radius'; did you mean 'robot_radius'"):
        load_robot_file(old)
    with pytest.raises(TypeError, match="radius"):
        Robot(radius=7.5)  # type: ignore[call-arg]
