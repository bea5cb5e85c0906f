"""Imports point one way (docs/architecture.md): vessels at the bottom, telemetry and commands
above it, sms above those, fleet on top; the edge client stands alone (it runs on the boat's Pi)."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
import tomllib
from importlib.metadata import packages_distributions
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[2]
# An app may import apps of a lower layer only; apps of one layer do not import each other.
# audit (the log every service writes) is the floor; operators (the operators' own API tokens
# and login limit) sits beside vessels; alerts watch everything below and notify through sms.
LAYER = {"audit": 0, "operators": 1, "vessels": 1, "telemetry": 2, "commands": 2, "sms": 3,
         "sbd": 3, "alerts": 4, "fleet": 5}  # fmt: skip
STANDALONE = {"edge_client": {"django", "rest_framework", *LAYER}}


def imported_packages(path: Path) -> list[tuple[int, str]]:
    """(line, top-level package) of every absolute import in a module, nested ones too."""
    return imported_packages_of(ast.parse(path.read_text(), str(path)))


def imported_packages_of(tree: ast.AST) -> list[tuple[int, str]]:
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name.split(".")[0]) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append((node.lineno, node.module.split(".")[0]))
    return found


def scan(app: str) -> tuple[int, list[str]]:
    """(how many imports were read, the ones that point the wrong way) for one app."""
    seen, bad = 0, []
    for path in sorted((ROOT / app).rglob("*.py")):
        for line, package in imported_packages(path):
            seen += 1
            if app in STANDALONE:
                wrong = package in STANDALONE[app]
            else:
                wrong = package in LAYER and package != app and LAYER[package] >= LAYER[app]
            if wrong:
                bad.append(f"{path.relative_to(ROOT)}:{line} imports {package}")
    return seen, bad


@pytest.mark.parametrize("app", [*LAYER, *STANDALONE])
def test_no_app_imports_upward(app: str) -> None:
    seen, bad = scan(app)
    assert seen > 0  # the app was found and read
    assert bad == []


# The boat's Pi installs the `[edge]` extra only (pyproject.toml): every package the edge client
# imports must be the standard library's, its own, or come with that extra.
def edge_extra() -> set[str]:
    """Distribution names in pyproject's `[edge]` extra, normalised."""
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    return {requirement_name(r) for r in pyproject["project"]["optional-dependencies"]["edge"]}


def requirement_name(requirement: str) -> str:
    return canonicalize_name(Requirement(requirement).name)


def test_edge_client_imports_only_what_its_extra_installs() -> None:
    extra, owners = edge_extra(), packages_distributions()
    missing = []
    for path in sorted((ROOT / "edge_client").rglob("*.py")):
        for line, package in imported_packages(path):
            if package in sys.stdlib_module_names or package in ("__future__", "edge_client"):
                continue
            dists = {requirement_name(d) for d in owners.get(package, [package])}
            if not dists & extra:
                missing.append(f"{path.relative_to(ROOT)}:{line} imports {package}")
    assert missing == []


def test_requirements_txt_is_the_edge_extra() -> None:
    """edge_client/requirements.txt (a Pi that copies the folder alone) is the `[edge]` list."""
    lines = (ROOT / "edge_client/requirements.txt").read_text().splitlines()
    listed = [line.strip() for line in lines if line.strip() and not line.startswith("#")]
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert listed == pyproject["project"]["optional-dependencies"]["edge"]


SERVER_PACKAGES = STANDALONE["edge_client"]  # what the edge client must never load
# Imports every module of the edge client, its simulator and transports included, then names
# any server package that came in with them (a module of a dependency may import one too).
LOADED = """
import pkgutil, importlib, sys
import edge_client
for module in pkgutil.walk_packages(edge_client.__path__, "edge_client."):
    if not module.name.endswith("__main__"):
        importlib.import_module(module.name)
print(" ".join(sorted({name.split(".")[0] for name in sys.modules})))
"""


def test_edge_client_loads_no_server_package_at_run_time() -> None:
    result = subprocess.run(
        [sys.executable, "-c", LOADED], cwd=ROOT, capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, result.stderr
    loaded = set(result.stdout.split())
    assert "edge_client" in loaded and "pymavlink" in loaded  # it did import them
    assert loaded & SERVER_PACKAGES == set()


# Pure logic (docs/architecture.md): importable and testable with no database, no port, no network.
PURE = [
    "commands/catalog.py",
    "commands/lifecycle.py",
    "commands/errors.py",
    "telemetry/parsing.py",
    "vessels/display.py",
    "vessels/clock.py",
    "vessels/errors.py",
    "vessels/missions.py",
    "vessels/missionfiles/__init__.py",
    "vessels/missionfiles/model.py",
    "vessels/missionfiles/mavitems.py",
    "vessels/missionfiles/plan.py",
    "vessels/missionfiles/waypoints.py",
    "vessels/missionfiles/geojson.py",
    "telemetry/errors.py",
    "telemetry/simplify.py",
    "telemetry/series.py",
    "telemetry/overview.py",
    "sms/gsm7.py",
    "fleet/map_actions.py",
    "sms/language.py",
    "sms/replies.py",
    "sms/errors.py",
    "sbd/errors.py",
    "sbd/rockblock.py",
    "sms/level2/codec.py",
    "sms/level2/framing.py",
    "sms/level2/bodies.py",
    "sms/level2/enumeration.py",
    "sms/level2/fields.py",
    "sms/level2/inner.py",
    "sms/level2/payload.py",
    "sms/level2/motion.py",
    "sms/bridge/records.py",
    "sms/bridge/machine.py",
    "sms/bridge/shore_config.py",
    "sms/modem/at.py",
    "sms/modem/error_codes.py",
    "sms/modem/errors.py",
    "alerts/notify/base.py",
    "alerts/notify/messages.py",
    "alerts/notify/signing.py",
    "edge_client/commands.py",
    "edge_client/geo.py",
    "edge_client/mission.py",
    "edge_client/fence_upload.py",
    "edge_client/sbd/at.py",
    "edge_client/sbd/errors.py",
    "edge_client/sbd/session_codes.py",
    *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "edge_client/contract").glob("*.py")),
]
IO = {"django", "rest_framework", "serial", "socket", "requests", "pymavlink", "sqlite3"}
# The one exception: MAVLink's names for its numbers come from pymavlink, which the boat and the
# server both install, loaded on first use inside a function and guarded by ImportError (the
# contract imports without it). Nothing else may lean on it.
GUARDED = {"edge_client/contract/mavcmd.py": {"pymavlink"}}


def guarded_imports(path: Path) -> set[tuple[int, str]]:
    """(line, top-level package) of the imports made inside a function under a ``try`` whose
    handler catches ImportError: loaded lazily, and the module imports without them."""
    found = set()
    for func in ast.walk(ast.parse(path.read_text(), str(path))):
        if not isinstance(func, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        for node in ast.walk(func):
            catches = isinstance(node, ast.Try) and any(
                isinstance(h.type, ast.Name) and h.type.id in ("ImportError", "ModuleNotFoundError")
                for h in node.handlers
            )
            if catches:
                module = ast.Module(body=node.body, type_ignores=[])
                found |= set(imported_packages_of(module))
    return found


def unguarded(module: str) -> set[str]:
    """The packages ``module`` imports, less the guarded ones GUARDED allows it."""
    path = ROOT / module
    allowed = {
        (line, package)
        for line, package in guarded_imports(path)
        if package in GUARDED.get(module, set())
    }
    return {package for line, package in imported_packages(path) if (line, package) not in allowed}


@pytest.mark.parametrize("module", PURE)
def test_pure_modules_import_no_io(module: str) -> None:
    assert unguarded(module) & IO == set()


def test_a_guarded_import_is_told_from_a_plain_one(tmp_path: Path) -> None:
    source = tmp_path / "m.py"
    source.write_text(
        "import os\n"
        "def f():\n"
        "    try:\n"
        "        import pymavlink\n"
        "    except ImportError:\n"
        "        return None\n"
        "    import serial\n"
    )
    assert guarded_imports(source) == {(4, "pymavlink")}
    assert {p for _, p in imported_packages(source)} == {"os", "pymavlink", "serial"}


# -- the boat–shore contract -------------------------------------------------------------------
# edge_client/contract/ is what the server and the boat share: stdlib and itself only, so the
# server may import it anywhere and a Pi that copies edge_client alone still has it.
CONTRACT = "edge_client.contract"


def dotted_imports(path: Path) -> list[tuple[int, str]]:
    """(line, full dotted name) of every absolute import in a module (``from a.b import c``
    gives ``a.b.c``, which is a module or a name in ``a.b``)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found += [(node.lineno, f"{node.module}.{alias.name}") for alias in node.names]
    return found


def test_the_contract_imports_only_the_standard_library_and_itself() -> None:
    modules = sorted((ROOT / "edge_client/contract").glob("*.py"))
    assert len(modules) >= 9  # __init__, kinds, catalog, geo, mavcmd, status, fix, batch, backoff
    bad = [
        f"{path.relative_to(ROOT)}:{line} imports {name}"
        for path in modules
        for line, name in dotted_imports(path)
        if name.split(".")[0] not in (*sys.stdlib_module_names, "__future__")
        and not name.startswith(f"{CONTRACT}.")
        and name.split(".")[0] not in unguarded_allowance(path)
    ]
    assert bad == []


def unguarded_allowance(path: Path) -> set[str]:
    """The packages ``path`` may import lazily and guarded (GUARDED), if it does so only."""
    module = str(path.relative_to(ROOT))
    allowed = GUARDED.get(module, set())
    return {p for p in allowed if p not in unguarded(module)}


# The server imports the boat's code in two places only, both the SMS bridge, which *is* an
# edge client for the Wave Gliders (it runs beside the modem and talks to the shore): its
# shore link reuses the outbox, the HTTP transport and the ack rules; its process loop the
# systemd notify. Everything else the server shares with the boat comes from the contract.
SERVER_MAY_IMPORT_EDGE = {
    "sms/bridge/shore.py": {
        "edge_client.client.COMMANDS_PATH",
        "edge_client.client.TELEMETRY_PATH",
        "edge_client.client.post_ack",
        "edge_client.outbox.Outbox",
        "edge_client.outbox.settle_fix_batch",
        "edge_client.transports.base.Transport",
        "edge_client.transports.base.TransportError",
        "edge_client.transports.http.HttpTransport",
    },
    "sms/bridge/process.py": {"edge_client.systemd"},
}


def test_the_server_imports_edge_code_only_through_the_contract_or_the_listed_bridge() -> None:
    found: dict[str, set[str]] = {}
    for app in LAYER:
        for path in sorted((ROOT / app).rglob("*.py")):
            for _, name in dotted_imports(path):
                if name.split(".")[0] == "edge_client" and not name.startswith(f"{CONTRACT}."):
                    found.setdefault(str(path.relative_to(ROOT)), set()).add(name)
    assert found == SERVER_MAY_IMPORT_EDGE


# -- import cycles -----------------------------------------------------------------------------
# No module of the project imports itself back, not even through a type hint under
# TYPE_CHECKING or an import inside a function: a cycle is a knot the layers above cannot see.
PROJECT = [*LAYER, *STANDALONE, "bench"]


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def project_modules() -> dict[str, Path]:
    return {module_name(path): path for app in PROJECT for path in (ROOT / app).rglob("*.py")}


def imported_modules(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The project's modules that ``name`` imports anywhere in it (``from a.b import c`` is
    ``a.b.c`` when that is a module, else ``a.b``); relative imports resolved."""

    def known(dotted: str) -> str | None:
        while dotted and dotted not in modules:
            dotted = dotted.rpartition(".")[0]
        return dotted or None

    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {known(alias.name) for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package[: len(package) - node.level + 1]
                base = ".".join([*up, *([node.module] if node.module else [])])
            found |= {known(f"{base}.{alias.name}") for alias in node.names}
    return found - {None, name}


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every group of modules that import each other round (Tarjan's strongly connected
    components with more than one module), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    cycles: list[list[str]] = []

    def visit(module: str) -> None:
        index[module] = low[module] = len(index)
        stack.append(module)
        for other in sorted(graph.get(module, ())):
            if other not in index:
                visit(other)
                low[module] = min(low[module], low[other])
            elif other in stack:
                low[module] = min(low[module], index[other])
        if low[module] == index[module]:
            group = []
            while not group or group[-1] != module:
                group.append(stack.pop())
            if len(group) > 1:
                cycles.append(sorted(group))

    for module in sorted(graph):
        if module not in index:
            visit(module)
    return cycles


def test_the_cycle_finder_finds_a_cycle_through_a_third_module() -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set()}
    assert import_cycles(graph) == [["a", "b", "c"]]


def test_no_module_imports_itself_back() -> None:
    modules = project_modules()
    graph = {name: imported_modules(name, path, modules) for name, path in modules.items()}
    assert "commands.errors" in graph["commands.lifecycle"]  # the graph was read
    assert import_cycles(graph) == []


# -- module size -------------------------------------------------------------------------------
MAX_LINES = 600


def test_no_module_is_over_600_lines() -> None:
    sizes = {
        str(path.relative_to(ROOT)): len(path.read_text().splitlines())
        for path in [*ROOT.glob("*.py"), *project_modules().values()]
    }  # tests are not modules of the project; nothing vendored is Python
    assert "edge_client/executor.py" in sizes  # the project was read
    long = {path: n for path, n in sizes.items() if n > MAX_LINES}
    assert long == {}


# -- hand-written SQL ----------------------------------------------------------------------------
# Each app's hand-written SQL lives in its sql.py, beside the benchmark that justifies it and
# tested on every database (tests/<app>/test_sql.py); everything else goes through the ORM.
RAW_SQL = re.compile(r"\bcursor\(|\.raw\(|\.execute(many)?\(|\bRawSQL\(|\.extra\(")


def test_hand_written_sql_lives_only_in_each_apps_sql_module() -> None:
    found = [
        f"{path.relative_to(ROOT)}:{n}"
        for app in LAYER
        for path in sorted((ROOT / app).rglob("*.py"))
        if path.name != "sql.py" and "migrations" not in path.parts
        for n, line in enumerate(path.read_text().splitlines(), 1)
        if RAW_SQL.search(line)
    ]
    assert found == []
