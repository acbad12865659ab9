"""A griffe extension for the rockjax API reference (mkdocs.yml loads it; not part of the package).

1. ``equinox.Module`` subclasses are dataclasses whose ``__init__`` equinox writes at class
   creation; griffe reads the source without running it, so it sees no ``__init__``. This
   extension writes the signature from the annotated fields (``eqx.field(default=...)`` and
   plain defaults; ``ClassVar`` and properties are not fields), so ``Block(b, h, length=1.0,
   ...)`` shows its real signature and its ``Args:`` match it.
2. Docstrings name other objects with the roles ``:func:`x```, ``:class:`x```, ``:meth:``,
   ``:attr:``, ``:data:``, ``:mod:`` (they read well in a terminal). In the site each becomes
   a link to ``x``'s entry when the reference documents it, and inline code when it does not.
   A one-line ``.. math:: formula`` becomes a displayed formula.
3. A private type alias in a public signature (``omega: _In`` in ``rockjax.relations``) is
   shown as what it stands for (``Real[ArrayLike, "..."]``).
"""

from __future__ import annotations

import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:func|class|meth|attr|data|mod|obj):`~?([A-Za-z_][\w.]*)(?:\(\))?`")
MATH_DIRECTIVE = re.compile(r"^(?P<indent>[ \t]*)\.\. math::[ \t]+(?P<tex>.+)$", re.MULTILINE)


def _field_default(attribute: griffe.Attribute) -> tuple[bool, Any]:
    """(has a default, the default expression) of an equinox field."""
    value = attribute.value
    if value is None:
        return False, None
    if isinstance(value, griffe.ExprCall) and str(value.function).split(".")[-1] == "field":
        for argument in value.arguments:
            name = getattr(argument, "name", None)
            if name == "default":
                return True, argument.value
            if name == "default_factory":
                return True, griffe.ExprCall(function=argument.value, arguments=[])
        return False, None
    return True, value


def _is_equinox_module(cls: griffe.Class) -> bool:
    try:
        mro = [cls, *cls.mro()]
    except ValueError:  # a base outside the loaded packages
        mro = [cls]
    return any(
        getattr(base, "canonical_path", "") == "equinox.Module" for c in mro for base in c.bases
    )


def _is_class_var(attribute: griffe.Attribute) -> bool:
    return "class-attribute" in attribute.labels and "instance-attribute" not in attribute.labels


def _equinox_init(cls: griffe.Class) -> None:
    if "__init__" in cls.members or not _is_equinox_module(cls):
        return
    required, optional = [], []
    for member in cls.members.values():
        if member.is_alias or not member.is_attribute or member.annotation is None:
            continue
        if "property" in member.labels or _is_class_var(member):
            continue
        has_default, default = _field_default(member)
        parameter = griffe.Parameter(
            member.name,
            annotation=member.annotation,
            kind=griffe.ParameterKind.positional_or_keyword,
            default=default if has_default else None,
        )
        (optional if has_default else required).append(parameter)
    init = griffe.Function(
        "__init__",
        lineno=cls.lineno,
        endlineno=cls.lineno,
        parent=cls,
        parameters=griffe.Parameters(
            griffe.Parameter("self", kind=griffe.ParameterKind.positional_or_keyword),
            *required,
            *optional,
        ),
        returns="None",
    )
    cls.set_member("__init__", init)


def _expand(obj: griffe.Object, annotation: Any) -> Any:
    """``annotation`` with a private module-level alias (``_In``) replaced by its value."""
    if not (isinstance(annotation, griffe.ExprName) and annotation.name.startswith("_")):
        return annotation
    alias = obj.module.members.get(annotation.name)
    if alias is None or alias.is_alias or not alias.is_attribute:
        return annotation
    return alias.value if isinstance(alias.value, griffe.Expr) else annotation


def _expand_aliases(function: griffe.Function) -> None:
    for parameter in function.parameters:
        parameter.annotation = _expand(function, parameter.annotation)
    function.returns = _expand(function, function.returns)


def _target(obj: griffe.Object, name: str, role: str) -> str | None:
    """The canonical path of ``name`` as seen from ``obj``, or None."""
    scopes = [obj, *_parents(obj)]
    head, _, tail = name.partition(".")
    for scope in scopes:
        try:
            found = scope.modules_collection[name] if name.startswith("rockjax") else None
        except KeyError:
            found = None
        if found is None and hasattr(scope, "members") and head in scope.members:
            found = scope.members[head]
            for part in tail.split(".") if tail else []:
                try:
                    found = found.members[part]
                except (KeyError, AttributeError, griffe.AliasResolutionError):
                    found = None
                    break
        if found is None:
            continue
        try:
            if (
                found.is_module
                and role in ("func", "class")
                and name.split(".")[-1] in found.members
            ):
                found = found.members[name.split(".")[-1]]  # rockjax.ida: the function
            return found.canonical_path if not found.is_alias else found.final_target.path
        except (griffe.AliasResolutionError, griffe.CyclicAliasError, AttributeError):
            return None
    return None


def _parents(obj: griffe.Object):
    parent = obj.parent
    while parent is not None:
        yield parent
        parent = parent.parent


def _rewrite(obj: griffe.Object, text: str) -> str:
    def role(match: re.Match) -> str:
        name = match.group(1)
        kind = match.group(0)[1:].split(":", 1)[0]
        shown = name.split(".")[-1] if match.group(0).find("`~") >= 0 else name
        target = _target(obj, name, kind)
        code = f"<code>{shown}</code>"
        if target is None:
            return f"`{shown}`"
        return f'<autoref identifier="{target}" optional>{code}</autoref>'

    text = ROLE.sub(role, text)
    return MATH_DIRECTIVE.sub(lambda m: f"{m['indent']}$${m['tex'].strip()}$$", text)


def _walk(obj: griffe.Object, seen: set[str]) -> None:
    if obj.path in seen:
        return
    seen.add(obj.path)
    if obj.docstring is not None:
        obj.docstring.value = _rewrite(obj, obj.docstring.value)
    if obj.is_class:
        _equinox_init(obj)
    if obj.is_function:
        _expand_aliases(obj)
    for member in list(obj.members.values()):
        if not member.is_alias:
            _walk(member, seen)


class RockjaxExtension(griffe.Extension):
    """Equinox signatures and Sphinx-style roles, for the rockjax site."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        _walk(pkg, set())
