"""Back-end options: a pydantic model per back end, filled from `--option key=value` strings.

    class SamplerOptions(BaseModel):
        model_config = ConfigDict(extra="forbid", frozen=True)
        tolerance: float = Field(0.1, gt=0, description="centroid distance tolerance x part size")

`parse_options(SamplerOptions, {"tolerance": "abc"}, backend="graph-sampler")` raises
`OptionError: --option tolerance=abc: graph-sampler expects a number greater than 0` instead
of a pydantic traceback. Keys may use `-` or `_`. `describe_options` lists the fields for
`grammarkit plugins`.
"""
from __future__ import annotations

from typing import Any, Mapping

from ..errors import GrammarkitError

__all__ = ["OptionError", "describe_options", "parse_options"]


class OptionError(GrammarkitError):
    """A back-end option that does not fit the back end's options model."""


def _field_key(model: Any, key: str) -> str | None:
    fields = model.model_fields
    for candidate in (key, key.replace("-", "_")):
        if candidate in fields:
            return candidate
    return None


def _plain(error: Mapping[str, Any]) -> str:
    """A pydantic error in plain words ("expects a number greater than 0")."""
    kind, ctx = error.get("type", ""), error.get("ctx") or {}
    words = {
        "float_parsing": "a number", "float_type": "a number", "int_parsing": "a whole number",
        "int_type": "a whole number", "int_from_float": "a whole number",
        "bool_parsing": "true or false", "bool_type": "true or false",
        "string_type": "text", "finite_number": "a finite number",
    }
    if kind in words:
        return f"expects {words[kind]}"
    bounds = {"greater_than": ("greater than", "gt"), "greater_than_equal": ("at least", "ge"),
              "less_than": ("less than", "lt"), "less_than_equal": ("at most", "le")}
    if kind in bounds:
        text, key = bounds[kind]
        return f"expects a value {text} {ctx.get(key)}"
    if kind in ("literal_error", "enum"):
        return f"expects one of {ctx.get('expected', '')}"
    return str(error.get("msg", "is not valid")).replace("Value error, ", "")


def parse_options(model: Any, raw: Mapping[str, Any] | Any | None, *, backend: str) -> Any:
    """An instance of the options `model` from `raw` (strings from the command line, Python
    values from the API, or an instance already). None model: no options allowed."""
    from pydantic import ValidationError

    if model is None:
        if raw:
            raise OptionError(f"back end {backend!r} takes no options; got "
                              + ", ".join(f"--option {k}=..." for k in dict(raw)))
        return None
    if isinstance(raw, model):
        return raw
    values: dict[str, Any] = {}
    given: dict[str, str] = {}
    for key, value in dict(raw or {}).items():
        name = _field_key(model, str(key))
        if name is None:
            known = ", ".join(sorted(k.replace("_", "-") for k in model.model_fields)) or "none"
            raise OptionError(f"--option {key}: {backend} has no option {key!r}; known options: {known}")
        if isinstance(value, str) and value.strip().lower() == "none" and \
                model.model_fields[name].default is None:
            value = None
        values[name] = value
        given[name] = f"{key}={value}"
    try:
        return model.model_validate(values)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = err.get("loc") or ("?",)
        name = str(loc[0])
        if err.get("type") == "missing":
            field = model.model_fields.get(name)
            about = f" ({field.description})" if field is not None and field.description else ""
            flag = name.replace("_", "-")
            raise OptionError(f"back end {backend!r} needs the option {flag!r}{about}; give "
                              f"--option {flag}=VALUE") from None
        where = f"--option {given.get(name, name)}"
        raise OptionError(f"{where}: {backend} option {name.replace('_', '-')!r} {_plain(err)}") from None


def describe_options(model: Any) -> list[dict[str, Any]]:
    """[{name, type, default, doc}] for every field of an options model."""
    if model is None:
        return []
    out = []
    for name, f in model.model_fields.items():
        ann = f.annotation
        type_name = getattr(ann, "__name__", None) or str(ann).replace("typing.", "")
        out.append({"name": name.replace("_", "-"), "type": type_name,
                    "default": f.default, "doc": f.description or ""})
    return out
