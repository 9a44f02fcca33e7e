"""The tree shows the architecture (docs/architecture.md).

- One import namespace: the card's folders are ``mjchar.bvh`` (``bvh/``), ``mjchar.controllers``
  (``controllers/``), ``mjchar.envs`` (``envs/``), ``mjchar.assets`` (``assets/``, data) and the
  application ``mjchar`` (``mjchar/``); nothing imports the folders by their own names.
- Layers: ``mjchar.bvh`` <- ``mjchar.controllers`` <- ``mjchar.envs`` <- the application; each
  imports only from the layers below it (the namespace root ``mjchar/__init__`` registers the
  envs and is below nothing). Inside ``mjchar.controllers`` the subpackages keep their own order
  (``core`` <- ``balance`` <- ``walking``; ``core`` <- ``sampling``), and inside ``mjchar.bvh``
  the subpackages by concern theirs (io <- kinematics <- rigs <- editing <- mjcf <- reference <-
  gait <- bundled).
- No import circle between files (every import counts: module level, inside functions, and
  under ``TYPE_CHECKING``).
- No module over 800 lines; every module of ``bvh/`` lives in a subpackage or is one of its
  documented top-level modules.
- The controller registry is the one list of controllers: a throwaway registration shows up in
  ``mjchar run``, in ``make_controller`` and in a one-cell bench matrix with no other edit, and
  every registered controller passes the same smoke test.
"""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mjchar import bench as B
from mjchar.bvh.bundled.assets import TRAJECTORIES
from mjchar.cli import main
from mjchar.commands import COMMANDS
from mjchar.controllers.core import registry
from mjchar.controllers.core import scenarios as S
from mjchar.controllers.core.action import Action
from mjchar.controllers.core.builder import RunError, RunSpec
from mjchar.controllers.core.registry import ControllerSpec, RegistryError
from mjchar.controllers.core.scenarios import registry as scenario_registry
from mjchar.controllers.core.scenarios.options import DURATION, SEED
from mjchar.controllers.core.scenarios.registry import Option, ScenarioError, ScenarioSpec

ROOT = Path(__file__).resolve().parents[1]
#: the repository's folders and the namespace each is mapped to (pyproject's package-dir)
FOLDERS = {"bvh": "mjchar.bvh", "controllers": "mjchar.controllers", "envs": "mjchar.envs",
           "mjchar": "mjchar"}
#: the layers, lowest first (the application is every other module under ``mjchar``)
LAYERS = ("mjchar.bvh", "mjchar.controllers", "mjchar.envs", "mjchar")
#: inside controllers: what each subpackage may import from its siblings
CONTROLLER_DEPS = {"core": set(), "balance": {"core"}, "walking": {"core", "balance"},
                   "sampling": {"core"}, "learned": {"core", "sampling"}}
#: inside bvh: the subpackages by concern, lowest first (each may import those before it)
BVH_ORDER = ("io", "kinematics", "rigs", "editing", "mjcf", "reference", "gait", "bundled")
#: modules of bvh/ at its top level: the package, and the two every concern builds on
BVH_TOP = {"mjchar.bvh", "mjchar.bvh.errors", "mjchar.bvh.rotations"}
MAX_LINES = 800


def _modules() -> dict[str, Path]:
    """``{dotted module name: file}`` for every module of the four folders."""
    out = {}
    for folder, namespace in FOLDERS.items():
        for f in sorted((ROOT / folder).rglob("*.py")):
            parts = list(f.relative_to(ROOT / folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join([namespace, *parts])] = f
    return out


MODULES = _modules()


def _from_target(node: ast.ImportFrom, package: list[str]) -> str:
    """The absolute module a ``from ... import`` in ``package`` names (relative levels
    resolved)."""
    if node.level:
        base = package[:len(package) - node.level + 1]
        return ".".join(base + ([node.module] if node.module else []))
    return node.module or ""


def _imports(name: str, path: Path) -> set[str]:
    """The project modules ``name`` imports (resolved to modules: ``from pkg import mod`` is an
    import of ``pkg.mod`` when that is a module, else of ``pkg``)."""
    is_pkg = path.name == "__init__.py"
    package = name.split(".") if is_pkg else name.split(".")[:-1]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            target = _from_target(node, package)
            for a in node.names:
                sub = f"{target}.{a.name}"
                found.add(sub if sub in MODULES else target)
    return {m for m in found if m.split(".")[0] == "mjchar" and m != name}


def _layer(module: str) -> int:
    for i, top in enumerate(LAYERS[:-1]):
        if module == top or module.startswith(top + "."):
            return i
    return len(LAYERS) - 1


GRAPH = {name: {m if m in MODULES else m.rsplit(".", 1)[0] for m in _imports(name, path)}
         for name, path in MODULES.items()}
#: an import of the folders by their own names (``import bvh``, ``from controllers.x import``)
OLD_NAME = re.compile(r"^\s*(from|import)\s+(bvh|controllers|envs|assets)\b", re.M)


def test_every_import_resolves_to_a_project_module():
    unknown = {(a, b) for a, deps in GRAPH.items() for b in deps if b not in MODULES}
    assert not unknown


def test_nothing_imports_the_folders_by_their_own_names():
    """The folders exist only as ``mjchar.*`` (an installed wheel has no ``bvh``, ``envs``...):
    no module, test or example imports them otherwise."""
    files = [*MODULES.values(), *(ROOT / "tests").rglob("*.py"), *(ROOT / "examples").rglob("*.py")]
    bad = [f"{f.relative_to(ROOT)}: {m.group(0).strip()}" for f in files
           for m in OLD_NAME.finditer(f.read_text())]
    assert not bad, "\n".join(bad)


def test_layers_import_only_from_below():
    upward = []
    for a, deps in GRAPH.items():
        if a == "mjchar":  # the namespace root registers the envs (lightly)
            continue
        for b in deps:
            if b != "mjchar" and _layer(b) > _layer(a):
                upward.append(f"{a} imports {b}")
    assert not upward, "\n".join(upward)


def _printed(code: str) -> list[str]:
    """The lines ``code`` prints, run in a fresh interpreter from the checkout's parent."""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       cwd=ROOT.parent)
    assert r.returncode == 0, f"exit status {r.returncode}; stderr:\n{r.stderr}"
    return r.stdout.splitlines()


PROJECT_MODULES = "sorted(m for m in sys.modules if m.split('.')[0] in ('mjchar', 'mujoco'))"


@pytest.mark.parametrize("order", ["mjchar, gymnasium as gym", "gymnasium as gym, mjchar"])
def test_import_mjchar_registers_the_envs_and_stays_light(order):
    """``import mjchar`` loads nothing of the project but the id registration (no MuJoCo, no
    Gymnasium); ``gymnasium.make`` finds the ids whichever was imported first, and the env
    classes load when it asks for them."""
    out = _printed(f"import sys; import mjchar; print({PROJECT_MODULES}, "
                   "'gymnasium' in sys.modules)")
    assert out == ["['mjchar', 'mjchar.gym_ids'] False"]
    out = _printed(f"import sys, {order}; print({PROJECT_MODULES}); "
                   "print(gym.spec('mjchar/Imitation-v0').entry_point)")
    assert out == ["['mjchar', 'mjchar.envs', 'mjchar.gym_ids']",
                   "mjchar.envs.imitation:ImitationEnv"]


def test_the_kinematic_layer_loads_neither_gymnasium_nor_the_controllers():
    out = _printed("import sys, mjchar.bvh; print(sorted({m.split('.')[0] for m in sys.modules "
                   "if m.startswith(('gymnasium', 'mjchar.controllers', 'mjchar.envs'))}))")
    assert out == ["[]"]


def test_mjchar_help_imports_no_controller():
    """``mjchar --help`` (and a misspelt subcommand) builds only the subcommands' names and
    lines of help; ``mjchar run --help`` builds run's parser, which lists the controllers."""
    code = ("import sys, contextlib, io; from mjchar.cli import main\n"
            "for argv in (['--help'], ['rnu']):\n"
            "    with contextlib.redirect_stdout(io.StringIO()), "
            "contextlib.redirect_stderr(io.StringIO()):\n"
            "        try: main(argv)\n"
            "        except SystemExit: pass\n"
            "print([m for m in sys.modules if m.startswith(('mjchar.controllers', 'gymnasium'))])")
    assert _printed(code) == ["[]"]
    r = subprocess.run([sys.executable, "-m", "mjchar", "--help"], capture_output=True,
                       text=True, cwd=ROOT.parent)
    assert r.returncode == 0 and all(f"    {c}" in r.stdout for c in COMMANDS), r.stdout


def test_controller_subpackages_keep_their_order():
    wrong = []
    for a, deps in GRAPH.items():
        pa = a.split(".")
        if pa[:2] != ["mjchar", "controllers"] or len(pa) < 4:
            continue
        for b in deps:
            pb = b.split(".")
            if pb[:2] == ["mjchar", "controllers"] and len(pb) > 2 and pb[2] != pa[2]:
                if pb[2] not in CONTROLLER_DEPS[pa[2]]:
                    wrong.append(f"{a} imports {b}")
    assert not wrong, "\n".join(wrong)


def test_bvh_lives_in_subpackages_by_concern():
    loose = [m for m in MODULES if m.startswith("mjchar.bvh.") and m not in BVH_TOP
             and m.split(".")[2] not in BVH_ORDER]
    assert not loose, f"modules of bvh/ outside its subpackages: {loose}"
    assert {m.split(".")[2] for m in MODULES if m.count(".") >= 3
            and m.startswith("mjchar.bvh.")} == set(BVH_ORDER)


def test_bvh_subpackages_keep_their_order():
    wrong = []
    for a, deps in GRAPH.items():
        pa = a.split(".")
        if pa[:2] != ["mjchar", "bvh"] or len(pa) < 4 or pa[2] not in BVH_ORDER:
            continue
        for b in deps:
            pb = b.split(".")
            if (pb[:2] == ["mjchar", "bvh"] and len(pb) > 2 and pb[2] in BVH_ORDER
                    and BVH_ORDER.index(pb[2]) > BVH_ORDER.index(pa[2])):
                wrong.append(f"{a} imports {b}")
    assert not wrong, "\n".join(wrong)


def test_no_import_circles_between_files():
    # Tarjan's strongly connected components over the file graph
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in GRAPH[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                circles.append(sorted(comp))

    for v in GRAPH:
        if v not in index:
            visit(v)
    assert not circles, circles


def test_the_graph_sees_real_edges():
    # the checks above are only as good as the graph: spot-check edges that must be there
    assert "mjchar.controllers.core.character" in GRAPH["mjchar.controllers.core.base"]
    assert "mjchar.controllers.core.registry" in GRAPH["mjchar.controllers.balance.hand_of_god"]
    assert "mjchar.controllers" in GRAPH["mjchar.bench.matrix"]  # from mjchar.controllers import
    assert "mjchar.bvh.io.motion" in GRAPH["mjchar.bvh.io.reader"]


#: the Character's former flat names, forwarders to its parts until the IPM walker went through
#: the parts too: gone, and nothing may call them
FORMER_FLAT_NAMES = ("mass", "qpos", "set_actuation", "default_gains", "torque_limits", "com",
                     "com_velocity", "mass_matrix", "point_jacobian", "ground_contacts",
                     "foot_contacts", "support_polygon", "on_floor", "solve_ik")


def test_the_character_has_no_flat_forwarders_left():
    """Everything uses the Character's parts (``character.state.qpos``, ...), the docs and
    examples included (which no call would catch)."""
    from mjchar.controllers.core.character import Character

    assert not [n for n in FORMER_FLAT_NAMES if hasattr(Character, n)]
    flat = re.compile(r"\b(?:character|ch|humanoid|mini)\.(" + "|".join(FORMER_FLAT_NAMES)
                      + r")\b")
    files = [*MODULES.values(), *(ROOT / "tests").rglob("*.py"),
             *(ROOT / "examples").rglob("*.py"), *(ROOT / "docs").glob("*.md"),
             ROOT / "README.md"]
    bad = [f"{f.relative_to(ROOT)}: {m.group(0)}" for f in files
           for m in flat.finditer(f.read_text())]
    assert not bad, "\n".join(bad)


#: where a run is built and simulated: the run builder and the scenarios
BUILDER = ("mjchar.controllers.core.builder", "mjchar.controllers.core.scenarios")
#: the scenarios' simulation entry points: a call of one outside the builder builds a run by hand
PROCEDURES = {"simulate", "run_scenario", "track", "walk", "stand", "push", "random_push",
           "slope_walk"}
SCENARIOS_PACKAGE = "mjchar.controllers.core.scenarios"


def _scenario_calls(name: str, path: Path) -> list[str]:
    """Calls in module ``name`` of a scenario procedure (:data:`PROCEDURES`) imported from the
    scenarios (``from ...scenarios.shared import simulate``; ``scenarios as S`` then
    ``S.track(...)``)."""
    tree = ast.parse(path.read_text(), str(path))
    is_pkg = path.name == "__init__.py"
    package = name.split(".") if is_pkg else name.split(".")[:-1]
    functions, modules = set(), set()
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom):
            continue
        target = _from_target(node, package)
        for a in node.names:
            if a.name in PROCEDURES and (target.startswith(SCENARIOS_PACKAGE) or target in (
                    "mjchar.controllers", "mjchar.controllers.core")):
                functions.add(a.asname or a.name)
            elif f"{target}.{a.name}".startswith(SCENARIOS_PACKAGE):
                modules.add(a.asname or a.name)
    where = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path.name
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        f = node.func
        if isinstance(f, ast.Name) and f.id in functions:
            found.append(f"{where}:{node.lineno} {f.id}(...)")
        elif (isinstance(f, ast.Attribute) and f.attr in PROCEDURES
              and isinstance(f.value, ast.Name) and f.value.id in modules):
            found.append(f"{where}:{node.lineno} {f.value.id}.{f.attr}(...)")
    return found


def test_every_run_is_built_by_the_builder():
    """One way in: outside the run builder and the scenarios (controllers/core/builder.py,
    controllers/core/scenarios/), no module simulates a run by hand (``simulate``,
    ``run_scenario`` or a scenario's procedure function): the CLI, the Python API, the bench, perf
    and the envs build every run with ``RunSpec``."""
    by_hand = [call for name, path in MODULES.items()
               if not name.startswith(BUILDER) for call in _scenario_calls(name, path)]
    assert not by_hand, "\n".join(by_hand)


def test_the_builder_test_sees_a_call_by_hand(tmp_path):
    """The check above finds both forms of a call by hand (a guard against a check that cannot
    fail)."""
    code = tmp_path / "by_hand.py"
    code.write_text("from mjchar.controllers.core import scenarios as S\n"
                    "from mjchar.controllers.core.scenarios.shared import simulate\n"
                    "from mjchar.controllers import run_scenario\n"
                    "S.track(1, 2, 3)\nsimulate(1, 2)\nrun_scenario(1)\n")
    calls = _scenario_calls("mjchar.perf.by_hand", code)
    assert sorted(c.split()[-1] for c in calls) == ["S.track(...)", "run_scenario(...)",
                                                    "simulate(...)"]


MAX_FUNCTION_LINES = 80


@pytest.mark.parametrize("folder", ["bvh", "controllers"])
def test_no_function_over_80_lines(folder):
    """The kinematic and dynamic layers read as steps: no function (``def`` to its last line)
    over :data:`MAX_FUNCTION_LINES` lines."""
    long = [f"{path.relative_to(ROOT)}:{node.lineno} {node.name} "
            f"({node.end_lineno - node.lineno + 1} lines)"
            for name, path in MODULES.items() if name.startswith(FOLDERS[folder])
            for node in ast.walk(ast.parse(path.read_text()))
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES]
    assert not long, "\n".join(long)


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_module_over_800_lines(name):
    n = len(MODULES[name].read_text().splitlines())
    assert n <= MAX_LINES, f"{MODULES[name].relative_to(ROOT)} has {n} lines"


# -- the registry ------------------------------------------------------------------------------
class Limp:
    """A controller that applies no torque at all: the character collapses."""

    name = "limp"
    actuation = "torque"

    def reset(self, character) -> None:
        character.actuation.set_mode(self.actuation)
        self.nv = character.nv

    def act(self, character, t: float) -> Action:
        return Action(torque=np.zeros(self.nv))


@pytest.fixture
def limp():
    spec = registry.register(ControllerSpec(
        name="limp", label="no torque (test)", kind="balance",
        factory=lambda character, target=None, **options: Limp(),
        abilities=("stand",), default_scenario="stand", bench=("stand",)))
    yield spec
    registry.unregister("limp")


def test_a_registration_reaches_the_cli_make_controller_and_the_bench(limp, capsys):
    assert "limp" in registry.names()
    assert isinstance(registry.make_controller("limp", None), Limp)
    # mjchar run: a choice, and it runs (the limp character falls)
    assert main(["run", "limp", "--duration", "3", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["controller"] == "limp" and out["scenario"] == "stand" and out["fell"]
    assert main(["run", "limp", "--scenario", "walk"]) == 2  # a scenario it cannot run
    # the bench: a row of the matrix, run as a one-cell matrix
    assert B.matrix()["limp"] == ("stand",)
    cfg = replace(B.quick_config(1), stand_duration=3.0)
    controllers, cells, _ = B.run_matrix([("limp", "stand")], cfg, progress=False)
    assert controllers["limp"]["available"]
    assert cells[0]["status"] == "ok" and not cells[0]["runs"][0]["survived"]


def test_a_declared_option_gets_its_flag_where_it_applies_and_its_range(monkeypatch, capsys):
    """Options are declared once: a controller taking a new declared option gets its flag in
    ``mjchar run`` (parsed by its kind, checked against its range) and its factory receives it;
    every other controller refuses the flag; an undeclared option cannot be registered."""
    from mjchar.controllers.core.registry import FACTORY_OPTIONS, FactoryOption

    monkeypatch.setitem(FACTORY_OPTIONS, "droop", FactoryOption(
        "droop", "--droop", "number", help="how far it sags", low=-2.0, high=2.0,
        unit="metres"))
    got = {}

    def factory(character, target=None, **options):
        got.update(options)
        return Limp()

    registry.register(ControllerSpec(
        name="droopy", label="droops (test)", kind="balance", factory=factory,
        abilities=("stand",), default_scenario="stand", options=("droop",)))
    try:
        assert main(["run", "droopy", "--droop", "0.5", "--duration", "0.1", "--json"]) == 0
        assert got == {"droop": 0.5}
        capsys.readouterr()
        assert main(["run", "droopy", "--droop", "3"]) == 2
        assert "--droop 3 is out of range: give metres within +-2" in capsys.readouterr().err
        assert main(["run", "pd", "--droop", "0.5"]) == 2
        err = capsys.readouterr().err
        assert "--droop does not apply to pd in the stand scenario; it is used by droopy" in err
        with pytest.raises(RunError, match="droop 3 is out of range"):
            RunSpec("droopy", options={"droop": 3.0}).check()
    finally:
        registry.unregister("droopy")
    with pytest.raises(RegistryError, match="not declared"):
        ControllerSpec(name="x", label="x", kind="balance", factory=factory,
                       abilities=("stand",), default_scenario="stand", options=("sag",))


def test_the_python_api_checks_the_declared_ranges_too():
    with pytest.raises(RunError, match=r"heading 10000 is out of range: give degrees within "
                                       r"\+-360"):
        RunSpec("ipm", "walk", options={"heading": 1e4}).check()


def test_after_unregistering_the_name_is_gone(limp):
    registry.unregister("limp")
    try:
        assert "limp" not in registry.names()
        with pytest.raises(RegistryError, match="unknown controller 'limp'"):
            registry.make_controller("limp", None)
        with pytest.raises(SystemExit):
            main(["run", "limp"])
    finally:
        registry.register(limp)  # the fixture unregisters it


def test_bad_registrations_are_refused(limp):
    with pytest.raises(RegistryError, match="already registered"):
        registry.register(limp)
    with pytest.raises(RegistryError, match="kind"):
        replace(limp, name="x", kind="dancer")
    with pytest.raises(RegistryError, match="default scenario"):
        replace(limp, name="x", default_scenario="walk")
    with pytest.raises(RegistryError, match="abilities"):
        replace(limp, name="x", abilities=("dance",))
    with pytest.raises(RegistryError, match="expected"):
        replace(limp, name="x", expected=("walk",))


# -- the scenario registry ------------------------------------------------------------------------
def _sway(run, *, duration: float = 2.0, seed: int = 0):
    """A throwaway scenario: stand from a seeded perturbation of the standing pose."""
    ch = run.character
    q, v = S.perturbed_start(ch, S.standing_pose(ch), None, seed, joint_noise=0.05)
    return S.simulate(ch, run.controller, duration=duration, scenario="sway", qpos=q, qvel=v,
                      seed=seed, **run.simulate_options())


@pytest.fixture
def sway():
    spec = scenario_registry.register(ScenarioSpec(
        name="sway", measures="stand from a perturbed pose (test)", procedure=_sway,
        needs=("stand",), options=(DURATION, SEED), default_duration=2.0))
    yield spec
    scenario_registry.unregister("sway")


def test_a_scenario_registration_reaches_the_cli_the_builder_and_the_bench(sway, capsys):
    """One module and one registration: the new scenario is in ``mjchar run --help``, runs
    from the CLI and the Python API with the same numbers, and runs in a one-cell bench."""
    from mjchar.cli import build_parser
    from mjchar.controllers import run

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert "sway" in sub.choices["run"].format_help()
    assert "sway" in registry.get("static_balance").scenarios()
    assert "sway" not in registry.get("simbicon").scenarios()  # it cannot stand
    assert main(["run", "static_balance", "--scenario", "sway", "--duration", "1", "--seed",
                 "3", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["scenario"] == "sway" and out["seed"] == 3 and not out["fell"]
    r = run("static_balance", "sway", duration=1.0, seed=3)
    assert r.sim_time_s == out["sim_time_s"] and r.com_drop_m == out["com_drop_m"]
    assert main(["run", "simbicon", "--scenario", "sway"]) == 2
    cfg = replace(B.quick_config(1), stand_duration=1.0)
    controllers, cells, _ = B.run_matrix([("static_balance", "sway")], cfg, progress=False)
    assert cells[0]["status"] == "ok", cells[0]["reason"]
    assert cells[0]["runs"][0]["result"]["scenario"] == "sway"
    assert B.select_cells(["static_balance"], ["sway"]) == [("static_balance", "sway")]


def test_bad_scenario_registrations_are_refused(sway):
    with pytest.raises(ScenarioError, match="already registered"):
        scenario_registry.register(sway)
    with pytest.raises(ScenarioError, match="needs"):
        replace(sway, name="x", needs=("fly",))
    other = Option("duration", "--duration", "count", "a different duration")
    with pytest.raises(ScenarioError, match="differs"):
        scenario_registry.register(replace(sway, name="x", options=(other,)))
    with pytest.raises(ScenarioError, match="takes no option 'force'"):
        scenario_registry.run_scenario("sway", None, None, force=3.0)


def test_the_time_step_is_the_controllers_unless_chosen():
    """make_controller gives the character its controller's registered step; a step chosen
    for the character is kept."""
    from mjchar.controllers import Character, make_controller

    ch = Character()
    assert ch.timestep == 0.002
    make_controller("simbicon", ch)
    assert ch.timestep == registry.get("simbicon").timestep == 0.001
    make_controller("spd", ch)  # another controller on the same character: the model's step
    assert registry.get("spd").timestep is None and ch.timestep == 0.002
    chosen = Character(timestep=0.0025)
    make_controller("simbicon", chosen)
    assert chosen.timestep == 0.0025


@pytest.mark.parametrize("name", registry.names())
def test_every_registered_controller_runs_its_default_scenario(name, capsys):
    """The same smoke test for every registration: half a second of its default scenario
    through ``mjchar run``, no divergence, and no fall where the bench expects it to survive."""
    spec = registry.get(name)
    argv = ["run", name, "--duration", "0.5", "--json"]
    if spec.kind == "replay" and not spec.trajectory_prefixes:
        argv.insert(2, str(sorted(TRAJECTORIES.glob("samcon*.npz"))[0]))
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert not out["diverged"]
    assert out["sim_time_s"] == pytest.approx(0.5, abs=0.02)
    if spec.default_scenario in spec.expected:
        assert not out["fell"]


def test_reference_floor_by_controller():
    """Only a controller with a root force follows a floating clip; the rest track it grounded."""
    from mjchar.controllers.core import registry

    floors = {n: registry.get(n).floor for n in registry.names()}
    assert floors["hand_of_god"] == "clip"
    assert {f for n, f in floors.items() if n != "hand_of_god"} == {"contact"}
