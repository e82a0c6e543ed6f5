"""The Python API: overrides applied, typed results, to_dict/to_json, deprecated aliases: the tests that run the bhr command."""


def test_follow_and_trajectory_are_plain_functions_in_modules_of_other_names():
    import inspect
    import subprocess
    import sys

    import bhr.model.generators
    import bhr.run.driver

    assert inspect.isfunction(bhr.follow) and bhr.follow is bhr.run.driver.follow
    assert inspect.isfunction(bhr.trajectory) and bhr.trajectory is bhr.model.generators.trajectory
    # the old module names still import, once more with a warning, and never shadow the functions
    code = ("import warnings, inspect\n"
            "warnings.simplefilter('error', DeprecationWarning)\n"
            "import bhr, bhr.follow, bhr.trajectory\n"
            "assert inspect.isfunction(bhr.follow) and inspect.isfunction(bhr.trajectory)\n"
            "try:\n"
            "    from bhr.follow import load_run\n"
            "except DeprecationWarning as w:\n"
            "    print(w)\n"
            "warnings.simplefilter('ignore', DeprecationWarning)\n"
            "from bhr.follow import load_run\n"
            "from bhr.trajectory import load_trajectory\n"
            "import bhr.run.driver, bhr.model.generators\n"
            "assert load_run is bhr.run.driver.load_run and load_trajectory is bhr.model.generators.load_trajectory\n"
            "assert inspect.isfunction(bhr.follow) and inspect.isfunction(bhr.trajectory)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "bhr.follow is deprecated; import load_run from bhr.run.driver"
