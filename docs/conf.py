"""Sphinx configuration of the occrl documentation site.

Build it (warnings are errors, as in ``.ci/run``)::

    pip install -e ".[docs]"
    python -m sphinx -W --keep-going -b html docs docs/_build/html

The API reference (``docs/api/*.rst``) documents every module of the package with autodoc and
napoleon (Google-style docstrings); :func:`check_api_coverage` fails the build when a name in a
module's ``__all__`` or a module is missing from it. The example notebooks under
``examples/notebooks`` are copied into ``docs/tutorials/`` (git-ignored) and executed by myst-nb at
build time in their fast setting (``OCCRL_NOTEBOOK_FAST=1``: fewer tasks and iterations, the same
steps), so every tutorial page shows its outputs and pictures; a cell that raises fails the build.
``python scripts/check_tutorial_pictures.py HTML_DIR`` checks afterwards that each page has a picture.
"""

from __future__ import annotations

import ast
import functools
import importlib
import inspect
import os
import pkgutil
import shutil
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("MUJOCO_GL", "egl")
# the tutorials' kernels inherit this environment: the notebooks' fast setting, and this checkout's
# occrl ahead of any other on the path
os.environ.setdefault("OCCRL_NOTEBOOK_FAST", "1")
os.environ["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])

import occrl  # noqa: E402
from sphinx.util import logging  # noqa: E402

LOGGER = logging.getLogger("occrl.docs")

project = "occrl"
author = "the occrl developers"
copyright = "occrl developers"
release = occrl.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
    "myst_nb",  # Markdown pages (myst-parser) and notebooks
]

exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints"]
templates_path: list[str] = []

# --- Markdown and notebooks -------------------------------------------------------------------
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3  # the lab and design pages link to their sections by GitHub-style anchors
# the tutorials are committed without outputs and executed here (an unchanged page is not re-read by
# an incremental build, so not re-executed); a cell may take minutes on a loaded 2-core machine
nb_execution_mode = "force"
nb_execution_timeout = 600
nb_execution_raise_on_error = True
nb_execution_in_temp = True  # files a notebook writes (GIFs) go to a temporary folder
nb_execution_show_tb = True
nb_merge_streams = True
nb_output_stderr = "remove"  # library log lines and progress-bar notices; an error still fails the build

# --- API reference ----------------------------------------------------------------------------
# undoc-members: every name in __all__ is listed, the constants without a doc comment too
autodoc_default_options = {"members": True, "undoc-members": True, "member-order": "bysource", "show-inheritance": True}
autodoc_typehints = "signature"
autodoc_preserve_defaults = True
autoclass_content = "both"  # class docstring and __init__ docstring together
# an override without a docstring (forward, step, _call, ...) shows none rather than its base
# class's (torch, TorchRL and Gymnasium docstrings are not written for napoleon)
autodoc_inherit_docstrings = False
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_rtype = False
napoleon_attr_annotations = True
napoleon_use_ivar = True  # "Attributes:" as fields: the properties they describe are members too
add_module_names = False

# --- HTML -------------------------------------------------------------------------------------
html_theme = "furo"
html_title = f"occrl {release}"
html_static_path: list[str] = []


# --- the tutorials: examples/notebooks/*.ipynb, copied in unchanged ---------------------------
def copy_notebooks() -> None:
    """Mirror ``examples/notebooks/*.ipynb`` into ``docs/tutorials/`` (git-ignored); a copy is
    only rewritten when its notebook changed, so incremental builds stay incremental."""
    source, target = ROOT / "examples" / "notebooks", DOCS / "tutorials"
    target.mkdir(exist_ok=True)
    wanted = {p.name: p for p in sorted(source.glob("*.ipynb"))}
    for stale in target.glob("*.ipynb"):
        if stale.name not in wanted:
            stale.unlink()
    for name, path in wanted.items():
        copy = target / name
        if not copy.is_file() or copy.read_bytes() != path.read_bytes():
            shutil.copy2(path, copy)


copy_notebooks()


# --- every public name documented --------------------------------------------------------------
@functools.cache
def occrl_modules() -> tuple:
    """Every module of the package (optional extras are installed for the docs build)."""
    names = ["occrl"] + [m.name for m in pkgutil.walk_packages(occrl.__path__, "occrl.") if not m.name.endswith(".__main__")]
    return tuple(importlib.import_module(n) for n in names)


def canonical_names(module, name: str) -> list[str]:
    """The names under which ``module.name`` may be documented: as itself, where its class or
    function is defined, or as the same object in another module's ``__all__``."""
    obj = getattr(module, name)
    found = [f"{module.__name__}.{name}"]
    qualname, modname = getattr(obj, "__qualname__", None), getattr(obj, "__module__", None)
    if isinstance(qualname, str) and isinstance(modname, str):
        found.append(f"{modname}.{qualname}")
    for other in occrl_modules():
        if other is not module and name in getattr(other, "__all__", ()) and getattr(other, name, None) is obj:
            found.append(f"{other.__name__}.{name}")
    return found


def check_api_coverage(app, env) -> None:
    """Warn (an error under ``-W``) for each module without an API entry and each name in a
    module's ``__all__`` that no API page documents."""
    domain = env.get_domain("py")
    objects, modules = set(domain.objects), set(domain.modules)
    for module in occrl_modules():
        if module.__name__ not in modules:
            LOGGER.warning("API reference: module %s is not documented (add it to a page under docs/api/)", module.__name__)
        for name in getattr(module, "__all__", ()):
            if not objects.intersection(canonical_names(module, name)):
                LOGGER.warning("API reference: %s.%s (in __all__) is not documented", module.__name__, name)


def module_constants(module) -> dict[str, tuple[list[str], str | None]]:
    """The public constants a module assigns at top level (those in ``__all__``, or every
    upper-case name of a module without one), each with the comments around its assignment
    (the comment lines right above it and the end of its line) and its annotation."""
    source = inspect.getsource(module)
    lines = source.splitlines()
    public = getattr(module, "__all__", None)
    found: dict[str, tuple[list[str], str | None]] = {}
    for node in ast.parse(source).body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
            name, annotation = node.targets[0].id, None
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            name, annotation = node.target.id, ast.unparse(node.annotation)
        else:
            continue
        if (name not in public) if public is not None else (name.startswith("_") or not name.isupper()):
            continue
        above, row = [], node.lineno - 2
        while row >= 0 and lines[row].lstrip().startswith("#") and not lines[row].lstrip().startswith("#:"):
            text = lines[row].strip().lstrip("#").strip()
            if not text or text.startswith("---"):  # a section rule such as "# --- shelf ---"
                break
            above.insert(0, text)
            row -= 1
        if row >= 0 and lines[row].lstrip().startswith("#:"):
            continue  # a Sphinx doc comment: autodoc documents it
        tail = lines[node.lineno - 1].split("  # ", 1)
        trailing = [tail[1].strip()] if len(tail) == 2 and node.end_lineno == node.lineno else []
        found[name] = (above + trailing, annotation)
    return found


def constant_directives(module) -> list[str]:
    """``py:data`` entries for the constants of a module: autodoc documents module-level data
    only when it has a ``#:`` doc comment, and the existing comments say what each one is."""
    out = []
    for name, (comments, annotation) in module_constants(module).items():
        value = getattr(module, name)
        text = " ".join(repr(value).split())
        out += ["", f".. py:data:: {name}"]
        if len(text) <= 100:
            out.append(f"   :value: {text}")
        out.append(f"   :type: {annotation or type(value).__name__}")
        out.append("")
        body = " ".join(comments)
        if isinstance(value, dict) and len(text) > 100:
            body += (" " if body else "") + "Keys: " + ", ".join(f"``{key!r}``" for key in value) + "."
        out += [f"   {body}", ""] if body else []
    return out


def docstring_summary(obj) -> str:
    """The first paragraph of an object's own docstring, on one line."""
    doc = obj.__doc__ if isinstance(obj, type) else inspect.getdoc(obj)
    if not isinstance(doc, str) or (isinstance(obj, type) and "__doc__" not in vars(obj)):
        return ""
    return " ".join(inspect.cleandoc(doc).split("\n\n", 1)[0].split())


def package_exports(module) -> list[str]:
    """A table of the names a package exports from its submodules, linked to their entries."""
    rows = []
    for export in getattr(module, "__all__", ()):
        names = canonical_names(module, export)
        target = next((n for n in names[1:] if n != names[0]), None)
        if target is None:
            continue  # defined in the package itself: documented on this page
        obj = getattr(module, export)
        if inspect.isclass(obj) or inspect.isroutine(obj):
            summary = docstring_summary(obj)
        else:
            owner = importlib.import_module(target.rsplit(".", 1)[0])
            summary = " ".join(module_constants(owner).get(export, ([], None))[0])
        rows += [f"   * - :py:obj:`{export} <{target}>`", f"     - {summary}"]
    if not rows:
        return []
    head = ["", f"Names exported by ``{module.__name__}`` (``from {module.__name__} import ...``):", ""]
    return head + [".. list-table::", "   :widths: 25 75", ""] + rows + [""]


def add_module_extras(app, what, name, obj, options, lines) -> None:
    """After a module's docstring: its package exports table and its constants."""
    if what != "module":
        return
    if hasattr(obj, "__path__") and obj is not occrl:
        lines += package_exports(obj)
    lines += constant_directives(obj)


def setup(app):
    app.connect("env-check-consistency", check_api_coverage)
    app.connect("autodoc-process-docstring", add_module_extras)
