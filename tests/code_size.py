"""Module and function sizes of the package, read from the source.

``python tests/code_size.py`` lists the largest modules and functions. A function's size is
its lines of code: lines of its body that hold code, without blank lines, comments and its
docstring (nested functions count toward both themselves and their parent)."""

from __future__ import annotations

import ast
import io
import pathlib
import tokenize

ROOT = pathlib.Path(__file__).resolve().parents[1]
SOURCES = ("spectral_materials", "benchmarks", "demos")


def source_files() -> list[pathlib.Path]:
    return sorted(p for d in SOURCES if (ROOT / d).is_dir() for p in (ROOT / d).rglob("*.py"))


def module_lines(path: pathlib.Path) -> int:
    return len(path.read_text(encoding="utf-8").splitlines())


def _code_lines(text: str) -> set[int]:
    """Line numbers that hold a token other than a comment, a newline or a string that is a
    statement of its own (a docstring)."""
    tree = ast.parse(text)
    docstrings = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        first = body[0] if isinstance(body, list) and body else None
        if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) \
                and isinstance(first.value.value, str):
            docstrings.update(range(first.lineno, first.end_lineno + 1))
    lines = set()
    skip = {tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT,
            tokenize.ENDMARKER}
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type not in skip:
            lines.update(range(tok.start[0], tok.end[0] + 1))
    return lines - docstrings


def functions(path: pathlib.Path) -> list[tuple[str, int]]:
    """(qualified name, lines of code of the body) of every function in ``path``."""
    text = path.read_text(encoding="utf-8")
    code = _code_lines(text)
    out = []

    def visit(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                first = child.body[0].lineno
                body = {n for n in code if first <= n <= child.end_lineno}
                out.append((f"{prefix}{child.name}", len(body)))
                visit(child, f"{prefix}{child.name}.")
            elif isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.")
            else:
                visit(child, prefix)

    visit(ast.parse(text), "")
    return out


def report(limit_module: int = 500, limit_function: int = 60) -> tuple[list, list]:
    modules, funcs = [], []
    for path in source_files():
        rel = path.relative_to(ROOT).as_posix()
        modules.append((module_lines(path), rel))
        funcs.extend((n, f"{rel}:{name}") for name, n in functions(path))
    modules.sort(reverse=True)
    funcs.sort(reverse=True)
    return ([m for m in modules if m[0] > limit_module],
            [f for f in funcs if f[0] > limit_function])


if __name__ == "__main__":
    big_modules, big_functions = report()
    everything = sorted(((module_lines(p), p.relative_to(ROOT).as_posix())
                         for p in source_files()), reverse=True)
    print("largest module:", everything[0])
    print(f"modules over 500 lines: {len(big_modules)}")
    for n, name in big_modules:
        print(f"  {n:5d}  {name}")
    print(f"functions over 60 lines of code: {len(big_functions)}")
    for n, name in big_functions:
        print(f"  {n:5d}  {name}")
