"""mkdocs hooks for the rockjax site (loaded by mkdocs.yml; not part of the package).

1. Notebooks are committed without outputs. Before the pages are rendered, every
   ``docs/notebooks/*.ipynb`` is executed (in parallel, one kernel per notebook) into
   ``.cache/rockjax-docs/``, and the site renders that executed copy. The copy is kept under a
   hash of the notebook and of the ``rockjax`` sources, so a rebuild that changed neither (a
   prose edit under ``./docs.sh serve``) executes nothing. A cell that raises fails the build.
   ``ROCKJAX_DOCS_EXECUTE=0`` renders the notebooks without outputs instead (a quick preview);
   ``ROCKJAX_DOCS_EXECUTE=reuse`` keeps the last executed copy even if rockjax changed since
   (a preview while editing rockjax; the site may then show outputs of older code).
2. The pages link to files outside ``docs/`` (``../benchmarks/bench_dem.py``,
   ``../experiments/results/*.png``), which read well on a code host but do not exist in a
   built site. Such files are added to the site under ``repo/``: images as they are, text
   files as a page that shows the highlighted source; links to a folder keep their text only.
3. Every name that rockjax/__init__.py re-exports must be rendered by a page of docs/api/; a
   name that none renders is a warning, so the strict build fails until it has a place.
4. Formulas are typeset when the site is built, not in the reader's browser: the ``$...$`` and
   ``$$...$$`` that ``pymdownx.arithmatex`` marks (in the pages and in the docstrings) become
   MathML (``latex2mathml``), which browsers render natively. The site needs no script and no
   font for its formulas, and reads the same offline and from disk (``file://``). The TeX
   stays in each formula as its annotation (copy and paste, screen readers). A formula that
   cannot be converted fails the build, naming the page and the formula. The notebook pages
   (nbconvert's template, through mkdocs-jupyter) lose two scripts they do not use: MathJax 2's
   set-up (its URL empty here; the notebooks' text has no formulas) and a loader of Mermaid
   from a CDN (they have no diagrams).
"""

from __future__ import annotations

import ast
import concurrent.futures
import hashlib
import html
import logging
import os
import posixpath
import re
import time
from pathlib import Path

from mkdocs.exceptions import PluginError
from mkdocs.plugins import event_priority
from mkdocs.structure.files import File, Files
from nbclient.exceptions import CellExecutionError

log = logging.getLogger("mkdocs.hooks.rockjax")

ROOT = Path(__file__).resolve().parents[2]
CACHE = ROOT / ".cache" / "rockjax-docs"
NOTEBOOK_TIMEOUT_S = 900  # per cell; the slowest cell (a calibration) takes about a minute
REPO_PREFIX = "repo/"
IMAGE_SUFFIXES = {".png", ".svg", ".jpg", ".jpeg", ".gif", ".pdf"}
LANGUAGES = {".py": "python", ".sh": "bash", ".toml": "toml", ".json": "json", ".csv": "text"}
# what pymdownx.arithmatex (generic: true) makes of $...$ and $$...$$: \(...\) in a span and
# \[...\] in a div, the TeX HTML-escaped
ARITHMATEX = re.compile(r'<(span|div) class="arithmatex">(.*?)</\1>', re.S)
# nbconvert's scripts in a notebook page: MathJax 2's set-up, and modules that load from a CDN
NOTEBOOK_SCRIPTS = re.compile(
    r"<!-- Load mathjax -->.*?<!-- End of mathjax configuration -->"
    r'|<script type="module">(?:(?!</script>).)*?https://cdnjs\.cloudflare\.com.*?</script>',
    re.S,
)
# a Markdown link or image whose target leaves docs/: ](../path) or ](../path#anchor)
OUTSIDE_LINK = re.compile(r"\]\((\.\./[^)\s#]*)(#[^)\s]*)?\)")


def _public_names() -> dict[str, str]:
    """``{name: module it comes from}`` for every ``from .m import x as x`` (and ``from . import
    m as m``) in rockjax/__init__.py, read from the source (importing would start JAX)."""
    tree = ast.parse((ROOT / "rockjax" / "__init__.py").read_text(encoding="utf-8"))
    names = {}
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            for alias in node.names:
                if alias.asname == alias.name:  # the explicit re-export form
                    names[alias.name] = node.module or alias.name
    return names


def _check_api_coverage(files: Files) -> None:
    """Warn (a strict build fails) about a public name that no API page renders: each needs
    ``::: rockjax.<name>``, or ``::: rockjax.<module>`` for the module it comes from."""
    rendered = set()
    for page in files.documentation_pages():
        if page.src_uri.startswith("api/") and page.src_uri.endswith(".md"):
            rendered |= set(re.findall(r"^::: rockjax\.([\w.]+)", page.content_string, re.M))
    for name, module in sorted(_public_names().items()):
        if name not in rendered and module not in rendered:
            log.warning(
                "rockjax.%s is public (rockjax/__init__.py) but no page of docs/api/ renders it: "
                "add '::: rockjax.%s' to the page where it belongs (mkdocs.yml lists them)",
                name,
                name,
            )


def _source_hash() -> str:
    digest = hashlib.sha256()
    for path in sorted((ROOT / "rockjax").rglob("*.py")):
        digest.update(path.relative_to(ROOT).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _execute(source: Path, target: Path) -> float:
    import nbformat
    from nbclient import NotebookClient

    start = time.perf_counter()
    nb = nbformat.read(source, as_version=4)
    NotebookClient(
        nb,
        timeout=NOTEBOOK_TIMEOUT_S,
        kernel_name="python3",
        resources={"metadata": {"path": str(source.parent)}},
    ).execute()
    tmp = target.with_suffix(".tmp")
    nbformat.write(nb, tmp)
    tmp.replace(target)  # atomic: an interrupted build leaves no half-written notebook
    return time.perf_counter() - start


def _executed_notebooks(notebooks: list[Path], reuse: bool) -> dict[Path, Path]:
    """Executed copies of ``notebooks`` (executing those not in the cache; with ``reuse``, only
    those never executed)."""
    CACHE.mkdir(parents=True, exist_ok=True)
    code = _source_hash()
    copies, todo = {}, []
    for nb in notebooks:
        key = hashlib.sha256(nb.read_bytes() + code.encode()).hexdigest()[:16]
        copy = CACHE / f"{nb.stem}-{key}.ipynb"
        older = sorted(CACHE.glob(f"{nb.stem}-*.ipynb"), key=lambda p: p.stat().st_mtime)
        if not copy.exists() and reuse and older:
            copy = older[-1]  # ROCKJAX_DOCS_EXECUTE=reuse: outputs of an earlier rockjax
        copies[nb] = copy
        if not copy.exists():
            todo.append(nb)
    if todo:
        # the kernels need the inline backend (figures as outputs) and this checkout of rockjax
        os.environ.pop("MPLBACKEND", None)
        paths = [str(ROOT), os.environ.get("PYTHONPATH", "")]
        os.environ["PYTHONPATH"] = os.pathsep.join(p for p in paths if p)
        workers = max(1, min(len(todo), os.cpu_count() or 1))
        log.info("executing %d notebook(s) on %d worker(s)", len(todo), workers)
        failed = []
        with concurrent.futures.ThreadPoolExecutor(workers) as pool:
            jobs = {pool.submit(_execute, nb, copies[nb]): nb for nb in todo}
            for job in concurrent.futures.as_completed(jobs):
                nb = jobs[job]
                try:
                    log.info("executed %s in %.0f s", nb.name, job.result())
                except CellExecutionError as err:
                    cell = next((ln for ln in str(err).splitlines()[2:] if ln.strip()), "")
                    failed.append(f"{nb.name}: {err.ename}: {err.evalue} (in the cell {cell!r})")
        if failed:
            raise PluginError(
                "a notebook cell raised, so the site would show an error:\n  "
                + "\n  ".join(failed)
                + "\nRun the notebook (jupyter, or pytest tests/test_notebooks.py) to see the "
                "traceback; ROCKJAX_DOCS_EXECUTE=0 builds the site without executing them."
            )
    for nb, copy in copies.items():  # drop stale copies of the same notebook
        for old in CACHE.glob(f"{nb.stem}-*.ipynb"):
            if old != copy:
                old.unlink()
    return copies


def _outside(target: Path, docs_dir: Path) -> bool:
    """Whether ``target`` is a file of the repository outside docs/."""
    return (
        target.is_file()
        and target.is_relative_to(ROOT)
        and not target.is_relative_to(docs_dir.resolve())
    )


def _outside_targets(files: Files, docs_dir: Path) -> set[str]:
    """Repository paths (relative to the root) of files that the pages link outside docs/."""
    found = set()
    for page in files.documentation_pages():
        if not page.src_uri.endswith(".md"):
            continue
        here = posixpath.dirname(page.src_uri)
        for match in OUTSIDE_LINK.finditer(page.content_string):
            target = (docs_dir / here / match.group(1)).resolve()
            if _outside(target, docs_dir):
                found.add(target.relative_to(ROOT).as_posix())
    return found


def _source_page(rel: str) -> str:
    text = (ROOT / rel).read_text(encoding="utf-8")
    fence = "````" if "```" in text else "```"
    lang = LANGUAGES.get(Path(rel).suffix, "text")
    return (
        f"# `{rel}`\n\nA file of the rockjax repository, shown as it was when this site was "
        f"built.\n\n{fence}{lang}\n{text}\n{fence}\n"
    )


def _repo_uri(rel: str) -> str:
    if Path(rel).suffix.lower() in IMAGE_SUFFIXES:
        return REPO_PREFIX + rel
    return REPO_PREFIX + rel + ".md"


@event_priority(-100)  # after mkdocs-jupyter wraps the notebook files (it reads abs_src_path)
def on_files(files: Files, config) -> Files:
    docs_dir = Path(config["docs_dir"])
    notebooks = [f for f in files if f.src_uri.endswith(".ipynb")]
    _check_api_coverage(files)
    execute = os.environ.get("ROCKJAX_DOCS_EXECUTE", "1")
    if execute not in ("0", "1", "reuse"):
        raise PluginError(f"ROCKJAX_DOCS_EXECUTE must be 1, 0 or reuse; got {execute!r}")
    if notebooks and execute != "0":
        copies = _executed_notebooks([Path(f.abs_src_path) for f in notebooks], execute == "reuse")
        for f in notebooks:
            f.abs_src_path = str(copies[Path(f.abs_src_path)])
    for rel in sorted(_outside_targets(files, docs_dir)):
        uri = _repo_uri(rel)
        if uri.endswith(".md"):
            files.append(File.generated(config, uri, content=_source_page(rel)))
        else:
            files.append(File.generated(config, uri, abs_src_path=str(ROOT / rel)))
    return files


def on_page_markdown(markdown: str, page, config, files) -> str:
    """Points links that leave docs/ at the copies ``on_files`` added (or drops folder links)."""
    docs_dir = Path(config["docs_dir"])
    here = posixpath.dirname(page.file.src_uri)

    def repoint(match: re.Match) -> str:
        target = (docs_dir / here / match.group(1)).resolve()
        if not _outside(target, docs_dir):
            return match.group(0)  # a page of the site, a folder, or missing: left as it is
        uri = _repo_uri(target.relative_to(ROOT).as_posix())
        return f"]({posixpath.relpath(uri, here or '.')}{match.group(2) or ''})"

    markdown = OUTSIDE_LINK.sub(repoint, markdown)
    # a link to a folder outside docs/ has no page in the site: keep its text only
    return re.sub(
        r"(!?)\[([^\]]*)\]\((\.\./[^)\s]*/)\)",
        lambda m: m.group(0) if m.group(1) else m.group(2),
        markdown,
    )


def _mathml(tex: str, display: str) -> str:
    """``tex`` as MathML (``display``: ``"inline"`` or ``"block"``), its TeX kept as the
    annotation."""
    from latex2mathml.converter import convert

    math = convert(tex, display=display)
    unknown = re.findall(r"\\[A-Za-z]+", html.unescape(re.sub(r"<[^>]+>", " ", math)))
    if unknown:  # latex2mathml writes a command it does not know as text
        raise ValueError(f"latex2mathml does not know {', '.join(sorted(set(unknown)))}")
    head, sep, rest = math.partition(">")
    body = rest.removesuffix("</math>")
    note = f'<annotation encoding="application/x-tex">{html.escape(tex)}</annotation>'
    return f"{head}{sep}<semantics>{body}{note}</semantics></math>"


@event_priority(100)  # before the search index reads the page
def on_page_content(content: str, page, config, files) -> str:
    """Typesets the page's formulas as MathML (item 4 of this module's docstring)."""

    def typeset(match: re.Match) -> str:
        tag, marked = match.groups()
        tex = html.unescape(marked).strip()
        if not (tex[:2] in ("\\(", "\\[") and tex[-2:] in ("\\)", "\\]")):
            return match.group(0)  # not arithmatex's delimiters: left as it is
        try:
            return _mathml(tex[2:-2].strip(), "block" if tag == "div" else "inline")
        except Exception as err:  # noqa: BLE001  (latex2mathml's errors share no base but this)
            raise PluginError(
                f"{page.file.src_uri}: cannot typeset the formula {tex!r} "
                f"({type(err).__name__}: {err}); write it in the TeX that latex2mathml reads"
            ) from err

    if page.file.src_uri.endswith(".ipynb"):
        content = NOTEBOOK_SCRIPTS.sub("", content)
    return ARITHMATEX.sub(typeset, content)
