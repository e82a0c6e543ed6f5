"""The Python API: overrides applied, typed results, to_dict/to_json, no deprecated aliases: the tests that run the bhr command."""


def test_follow_and_trajectory_are_plain_functions_in_modules_of_other_names():
    import inspect
    import subprocess
    import sys

    import bhr.model._generators
    import bhr._run.driver

    assert inspect.isfunction(bhr.follow) and bhr.follow is bhr._run.driver.follow
    assert inspect.isfunction(bhr.trajectory) and bhr.trajectory is bhr.model._generators.trajectory
    # the flat module names of before the layers are gone: one name per module
    code = ("import importlib, inspect, bhr\n"
            "for old in ('bhr.clearance', 'bhr.driver', 'bhr.atomic'):\n"
            "    try:\n"
            "        importlib.import_module(old)\n"
            "    except ModuleNotFoundError:\n"
            "        print('gone', old)\n"
            "assert inspect.isfunction(bhr.follow) and inspect.isfunction(bhr.trajectory)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split("\n")[:3] == ["gone bhr.clearance", "gone bhr.driver", "gone bhr.atomic"]
