"""One installable root, ``drivestyle``, that a user's own ``envs/`` cannot shadow; its command."""

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

USER_PACKAGES = (
    "envs", "recorded", "planning", "agents", "studies", "irl", "prediction", "scripts", "common"
)  # fmt: skip


def test_a_users_own_envs_folder_neither_shadows_nor_is_shadowed(tmp_path):
    for name in USER_PACKAGES:
        (tmp_path / name).mkdir()
        (tmp_path / name / "__init__.py").write_text(f"WHO = 'user {name}'\n")
    code = (
        "import gymnasium as gym, drivestyle, envs, agents\n"
        "env = gym.make('drivestyle/LaneChange-v0')\n"
        "obs, _ = env.reset(seed=0)\n"
        "import drivestyle.agents.smpc, drivestyle.irl.paper.learner, drivestyle.studies.paper\n"
        "import drivestyle.recorded\n"
        "print(envs.WHO, agents.WHO, obs.shape, drivestyle.envs.__name__)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["user", "envs", "user", "agents", "(8,)", "drivestyle.envs"]


def test_the_installed_command_lists_its_subcommands_and_answers_help(tmp_path):
    exe = shutil.which("drivestyle")
    assert exe is not None, "the console command 'drivestyle' is not installed (pip install -e .)"
    top = subprocess.run([exe, "--help"], capture_output=True, text=True, cwd=tmp_path)
    assert top.returncode == 0 and "learn-style" in top.stdout and "mine-styles" in top.stdout
    sub = subprocess.run([exe, "learn-style", "--help"], capture_output=True, text=True)
    assert sub.returncode == 0 and "usage: drivestyle learn-style" in sub.stdout
    bad = subprocess.run([exe, "no-such-command"], capture_output=True, text=True)
    assert bad.returncode == 2 and "unknown command" in bad.stderr


def test_every_script_is_a_subcommand():
    from drivestyle.scripts import COMMANDS

    scripts = {
        p.stem.replace("_", "-") for p in (ROOT / "scripts").glob("*.py") if p.stem != "__init__"
    }
    assert scripts == set(COMMANDS)


@pytest.mark.slow
def test_the_wheel_installs_one_root_package(tmp_path):
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
         "-w", str(tmp_path), str(ROOT)],
        check=True, capture_output=True, timeout=300,
    )  # fmt: skip
    (wheel,) = tmp_path.glob("drivestyle-*.whl")
    with zipfile.ZipFile(wheel) as zf:
        names = zf.namelist()
    tops = {n.split("/")[0] for n in names}
    assert {t for t in tops if not t.endswith(".dist-info")} == {"drivestyle"}
    for module in ("envs/lane_change.py", "recorded/readers/table.py", "planning/smpc_problem.py",
                   "planning/plan_solver_driver.c", "irl/paper/learner.py",
                   "studies/paper/study.py", "prediction/methods.py", "studies/prediction/study.py",
                   "scripts/learn_style.py", "common/io.py", "py.typed"):  # fmt: skip
        assert f"drivestyle/{module}" in names
