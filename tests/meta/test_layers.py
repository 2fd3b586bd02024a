"""The package's layers (``docs/architecture.md``): imports point down only, no cycles.

Every ``suspopt`` module belongs to one layer; a module may import from its own package
and from the layers below its own, never from a layer above or beside it. The check reads
every import statement of the package (function-level ones included)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / 'suspopt'

#: bottom to top; the packages of one tuple are independent of each other
LAYERS: tuple[tuple[str, ...], ...] = (
    ('errors',),
    ('inputs', 'interrupts', 'quiet'),
    ('records', 'curves'),
    ('road', 'multibody', 'driver'),
    ('models',),
    ('spectral',),
    ('spec',),
    ('transcription',),
    ('verification',),
    ('output',),
    ('studies',),
    ('sweep',),
    ('cli',),
)
LEVEL = {pkg: i for i, layer in enumerate(LAYERS) for pkg in layer}


def _package(module: str) -> str:
    return module.split('.')[1] if module.count('.') else ''


def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text())
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module == 'suspopt':
                out += [(node.lineno, f'suspopt.{a.name}') for a in node.names]
            elif node.module.startswith('suspopt.'):
                out.append((node.lineno, node.module))
        elif isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if a.name.startswith('suspopt.')]
    return out


def _modules() -> list[Path]:
    return sorted(PACKAGE.rglob('*.py'))


def test_every_package_has_a_layer():
    packages = {p.relative_to(PACKAGE).parts[0].removesuffix('.py') for p in _modules()}
    packages -= {'__init__'}
    assert packages <= set(LEVEL), f'not in LAYERS: {sorted(packages - set(LEVEL))}'


@pytest.mark.parametrize('path', _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_point_down(path):
    own = path.relative_to(PACKAGE).parts[0].removesuffix('.py')
    if own == '__init__':
        return
    bad = []
    for line, module in _imports(path):
        other = _package(module)
        if other == own:
            continue
        if other not in LEVEL or LEVEL[other] >= LEVEL[own]:
            bad.append(f'line {line}: {module} ({other!r} is not below {own!r})')
    assert not bad, '\n'.join(bad)


def _module_name(path: Path) -> str:
    parts = ('suspopt',) + path.relative_to(PACKAGE).with_suffix('').parts
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def _runtime_imports(path: Path) -> set[str]:
    """The suspopt modules ``path`` imports when it runs (``if TYPE_CHECKING:`` left out)."""
    tree = ast.parse(path.read_text())
    skip = {
        id(n)
        for node in ast.walk(tree)
        if isinstance(node, ast.If) and 'TYPE_CHECKING' in ast.unparse(node.test)
        for n in ast.walk(node)
    }
    return {m for node in ast.walk(tree) if id(node) not in skip for _, m in _imports_of(node)}


def _imports_of(node: ast.AST) -> list[tuple[int, str]]:
    if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
        if node.module == 'suspopt':
            return [(node.lineno, f'suspopt.{a.name}') for a in node.names]
        if node.module.startswith('suspopt.'):
            return [(node.lineno, node.module)]
    if isinstance(node, ast.Import):
        return [(node.lineno, a.name) for a in node.names if a.name.startswith('suspopt.')]
    return []


def test_no_import_cycles():
    graph = {_module_name(p): _runtime_imports(p) for p in _modules()}
    names = set(graph)

    def target(module: str) -> str:  # ``from suspopt.x import y`` where y is a module
        return module if module in names else module.rsplit('.', 1)[0]

    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> None:
        state[node] = 1
        stack.append(node)
        for dep in sorted(graph.get(node, ())):
            dep = target(dep)
            if dep == node or dep not in graph:
                continue
            if state.get(dep) == 1:
                cycle = stack[stack.index(dep) :] + [dep]
                raise AssertionError('import cycle: ' + ' -> '.join(cycle))
            if dep not in state:
                visit(dep)
        stack.pop()
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node)
