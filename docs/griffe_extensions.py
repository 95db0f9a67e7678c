"""Griffe extensions for the API page (mkdocs.yml names them).

``EquinoxModules``: an equinox Module is a dataclass (its metaclass makes it one), so give it
the ``__init__`` that equinox generates from its annotated fields, as griffe's built-in
extension does for ``@dataclass``. Without it the API page shows ``NoiseModel()`` with no
parameters and every documented parameter is reported as absent from the signature.

``SphinxRoles``: the docstrings name other objects with Sphinx roles (``:func:`~x.y```), which
Markdown would print as they are; they are shown as code, the short name where ``~`` asks
for it.

``SignatureDefaults``: every parameter's default on the page is the signature's. Griffe's numpy
parser gives the parameters of one entry (``start, stop : float``) the first one's default, so
the page once showed ``gaps`` of ``fit_fleet`` as None (it is "error"); the defaults are taken
from the signature, after the parse, so that a docstring cannot make them wrong
(``tests/test_docs.py`` reads them back off the built page)."""

import re

from griffe import (
    Attribute,
    Class,
    Docstring,
    DocstringSectionParameters,
    Expr,
    ExprCall,
    ExprKeyword,
    Extension,
    Function,
    Object,
    Parameter,
    ParameterKind,
    Parameters,
)

_MODULE_BASES = {"equinox.Module", "equinox._module.Module"}


def _is_equinox_module(class_: Class) -> bool:
    return any(
        isinstance(base, Expr) and base.canonical_path in _MODULE_BASES for base in class_.bases
    )


def _default(attribute: Attribute):
    """The field's default: ``eqx.field(default=...)`` or a plain value; None when required."""
    value = attribute.value
    if isinstance(value, ExprCall) and str(value.function).endswith("field"):
        for argument in value.arguments:
            if isinstance(argument, ExprKeyword) and argument.name == "default":
                return argument.value
        return None
    return value


class EquinoxModules(Extension):
    def on_class_members(self, *, cls: Class, **kwargs) -> None:
        if "__init__" in cls.members or not _is_equinox_module(cls):
            return
        fields = [
            member
            for member in cls.members.values()
            if isinstance(member, Attribute)
            and member.annotation is not None
            and "property" not in member.labels
        ]
        cls.set_member(
            "__init__",
            Function(
                "__init__",
                lineno=0,
                endlineno=0,
                parent=cls,
                parameters=Parameters(
                    Parameter("self", kind=ParameterKind.positional_or_keyword),
                    *(
                        Parameter(
                            field.name,
                            annotation=field.annotation,
                            kind=ParameterKind.positional_or_keyword,
                            default=_default(field),
                        )
                        for field in fields
                    ),
                ),
                returns="None",
            ),
        )


_ROLE = re.compile(r":(?:func|class|meth|attr|mod|data|exc|obj):`(~?)([^`]+)`")


def _as_code(match: re.Match) -> str:
    short, target = match.groups()
    return f"`{target.rsplit('.', 1)[-1] if short else target}`"


class SphinxRoles(Extension):
    def on_instance(self, *, obj: Object, **kwargs) -> None:
        docstring: Docstring | None = obj.docstring
        if docstring is not None and ":`" in docstring.value:
            docstring.value = _ROLE.sub(_as_code, docstring.value)


def _defaults_from_signature(sections: list, parent) -> list:
    """``sections`` with each documented parameter's default set to the signature's."""
    try:
        signature = parent.parameters
    except AttributeError:  # an object without parameters
        return sections
    for section in sections:
        if isinstance(section, DocstringSectionParameters):
            for parameter in section.value:
                if parameter.name in signature:
                    parameter.value = signature[parameter.name].default
    return sections


class SignatureDefaults(Extension):
    def on_instance(self, *, obj: Object, **kwargs) -> None:
        docstring: Docstring | None = obj.docstring
        if docstring is None or not isinstance(obj, (Function, Class)):
            return
        parse = docstring.parse

        def parse_with_signature_defaults(*args, **options):
            return _defaults_from_signature(parse(*args, **options), docstring.parent)

        docstring.parse = parse_with_signature_defaults
