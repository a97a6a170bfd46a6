"""The plugin manager: loads entry points of group ``grammarkit`` and collects what they provide.

Hooks are called in pluggy's call order (`tryfirst`/`trylast`, then the later registered
first), one implementation at a time, so that a broken plugin is reported with its name and
skipped while everything else keeps working (`grammarkit plugins` lists the failure):

- an entry point that fails to import, or a hook that raises (even `SystemExit`), is recorded
  against its plugin; a `KeyboardInterrupt` (Ctrl-C, or SIGTERM on the command line) is the
  user's stop and is re-raised;
- every item a hook returns is checked against the hook's spec type (an OperationSpec from
  `grammarkit_operations`, ...); a wrong item is reported and dropped, the rest is kept;
- a name provided twice is an error naming both plugins. A built-in (an entry point of
  grammarkit's own distribution) is never replaced; between other plugins the first in
  pluggy's call order wins;
- what plugins print while loading goes to stderr, so `--json` output stays valid.

`GRAMMARKIT_DISABLE_PLUGINS=name,...` skips the named entry points; `GRAMMARKIT_NO_PLUGINS=1`
(the CLI's `--no-plugins`) skips every entry point that is not a built-in.

The core never reads the process-wide manager: it receives a `grammarkit.registry.Registries`.
Only the CLI and the public API functions call `default_registries()` when given none.
"""
from __future__ import annotations

import contextlib
import importlib.metadata as md
import io
import os
import sys
import threading
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Iterable, Iterator

import pluggy

from . import hookspecs
from .errors import PluginError
from .registry import (
    BackendSpec, ConstraintSpec, ExporterSpec, FitSpec, FunctionSpec, OperationSpec, Registries,
)

ENTRY_POINT_GROUP = "grammarkit"
# Entry points of this distribution are the built-ins: never replaced by another plugin.
BUILTIN_DISTRIBUTION = "grammarkit"
DISABLE_ENV = "GRAMMARKIT_DISABLE_PLUGINS"
NO_PLUGINS_ENV = "GRAMMARKIT_NO_PLUGINS"

__all__ = ["DISABLE_ENV", "ENTRY_POINT_GROUP", "NO_PLUGINS_ENV", "PluginInfo", "PluginManager",
           "default_registries", "get_plugin_manager", "iter_errors", "reset_plugin_manager"]


@dataclass
class PluginInfo:
    name: str
    distribution: str = ""
    version: str = ""
    module: str = ""
    provides: dict[str, list[str]] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)
    builtin: bool = False
    disabled: bool = False

    @property
    def ok(self) -> bool:
        return not self.errors

    @property
    def status(self) -> str:
        return "disabled" if self.disabled else ("ok" if self.ok else "error")


@dataclass(frozen=True)
class _Kind:
    """One kind of contribution: its hook, the spec type its items must have, their name."""

    hook: str
    label: str  # in messages and `provides`
    spec: Any  # a type, or a callable returning it (click is imported only when needed)
    key: Callable[[Any], Any]
    callables: tuple[str, ...] = ()  # fields that must be callable (or None)


def _click_command() -> type:
    import click

    return click.Command


KINDS: dict[str, _Kind] = {
    "operations": _Kind("grammarkit_operations", "operation", OperationSpec, lambda o: o.name, ("apply",)),
    "functions": _Kind("grammarkit_functions", "function", FunctionSpec, lambda f: f.name, ("impl",)),
    "constraints": _Kind("grammarkit_constraints", "constraint", ConstraintSpec, lambda c: c.name, ("check",)),
    "backends": _Kind("grammarkit_backends", "backend", BackendSpec, lambda b: b.name, ("run",)),
    "exporters": _Kind("grammarkit_exporters", "exporter", ExporterSpec, lambda e: e.format,
                       ("encode", "check")),
    "fits": _Kind("grammarkit_insert_fits", "fit", FitSpec, lambda f: f.name, ("fit",)),
    "cli_commands": _Kind("grammarkit_cli_commands", "command", _click_command, lambda c: c.name),
    "train_commands": _Kind("grammarkit_train_commands", "train command", _click_command, lambda c: c.name),
}


def _env_names(value: str | None) -> set[str]:
    return {n.strip() for n in (value or "").split(",") if n.strip()}


def _env_flag(value: str | None) -> bool:
    return (value or "").strip().lower() in ("1", "true", "yes", "on")


@contextlib.contextmanager
def _plugin_output() -> Iterator[None]:
    """What a plugin prints to stdout goes to stderr (stdout may be a JSON document)."""
    target = sys.stderr if sys.stderr is not None else io.StringIO()
    with contextlib.redirect_stdout(target):
        yield


def _describe(item: Any) -> str:
    if isinstance(item, (str, bytes, int, float, bool)) or item is None:
        text = repr(item)
        return f"{type(item).__name__} {text if len(text) <= 40 else text[:37] + '...'}"
    name = getattr(item, "name", None)
    return f"a {type(item).__name__}" + (f" ({name!r})" if isinstance(name, str) else "")


def _problem(item: Any, kind: _Kind) -> str | None:
    """Why `item` cannot be a contribution of this kind (None: it can)."""
    spec = kind.spec if isinstance(kind.spec, type) else kind.spec()
    if not isinstance(item, spec):
        article = "an" if spec.__name__[0] in "AEIOU" else "a"
        return f"{_describe(item)} where {article} {spec.__name__} belongs"
    try:
        name = kind.key(item)
    except Exception:  # noqa: BLE001 - a malformed object of the right type
        name = None
    if not isinstance(name, str) or not name.strip():
        return f"{_describe(item)} whose name is {name!r}, not a non-empty string"
    for attr in kind.callables:
        value = getattr(item, attr, None)
        if value is not None and not callable(value):
            return f"{spec.__name__} {name!r} whose {attr} is {_describe(value)}, not a function"
    return None


def _items(result: Any) -> list:
    """A hook's result as a list; a string, a mapping or a single spec is refused."""
    if result is None:
        return []
    if isinstance(result, (str, bytes, dict)) or not isinstance(result, Iterable) \
            or hasattr(result, "__dataclass_fields__"):
        raise TypeError(f"returned {_describe(result)}, not a list of specs")
    return list(result)


class GuardedConstraint:
    """A third-party constraint's `check`, made safe for every caller (validate, the samplers):
    an exception (even SystemExit) or a result that is not a list of messages becomes a
    PluginError naming the plugin and the constraint, never a traceback or a silent pass. A
    class, not a closure, so that specs stay picklable for worker processes."""

    def __init__(self, plugin: str, name: str, check: Callable[..., Any]):
        self.plugin, self.name, self.check = plugin, name, check

    def __call__(self, *args: Any, **kwargs: Any) -> list[str]:
        from .errors import GrammarkitError

        who = f"plugin {self.plugin!r}: constraint {self.name!r}"
        try:
            result = self.check(*args, **kwargs)
            # None is not "no violations": a check that forgot to return would pass every shape
            messages = list(result) if result is not None and not isinstance(result, (str, bytes)) else None
        except GrammarkitError:
            raise
        except (Exception, SystemExit) as exc:  # noqa: BLE001 - the plugin's fault, named
            raise PluginError(f"{who} failed: {type(exc).__name__}: {exc}") from None
        bad = messages is None or [m for m in messages if not isinstance(m, str)]
        if bad:
            raise PluginError(f"{who} returned {_describe(result)}, not a list of messages")
        return messages


class GuardedFunction:
    """A third-party expression function: any exception it raises (even SystemExit) becomes a
    ValueError naming the plugin, which the evaluator reports at the call in the grammar
    (`g.grammar:2:18: error: boom(): plugin 'x' failed: RuntimeError: ...`)."""

    def __init__(self, plugin: str, name: str, impl: Callable[..., Any]):
        self.plugin, self.name, self.impl = plugin, name, impl

    def __call__(self, *args: Any) -> Any:
        from .errors import GrammarkitError

        try:
            return self.impl(*args)
        except GrammarkitError:
            raise
        except (Exception, SystemExit) as exc:  # noqa: BLE001 - the plugin's fault, named
            raise ValueError(f"plugin {self.plugin!r} failed: {type(exc).__name__}: {exc}") from None


class Application:
    """The one object every hook receives (`def grammarkit_backends(app): ...`), created with
    the plugin manager at the edge (the command line, the top-level Python API), as pytest's
    `Config` or datasette's `Datasette`: what a plugin may ask of grammarkit, in one place.

    registries: what every plugin provides (`grammarkit.registry.Registries`); a hook must
                not read the kind it is itself collecting.
    manager:    the PluginManager (plugins, their problems).
    version:    grammarkit's version."""

    def __init__(self, manager: "PluginManager"):
        self.manager = manager

    @property
    def registries(self) -> Registries:
        return self.manager.registries()

    @property
    def version(self) -> str:
        try:
            return md.version(BUILTIN_DISTRIBUTION)
        except md.PackageNotFoundError:  # pragma: no cover - run from a source tree
            return "unknown"


@dataclass(frozen=True)
class Contribution:
    """What one hook implementation returned, as the guard hands it to pluggy: the plugin's
    name and its items (hook wrappers see these in pluggy's result list)."""

    plugin: str
    items: tuple


class _GuardedHook:
    """Wraps one hook implementation inside pluggy's call (pluggy still orders and calls it,
    hook wrappers still run): what it prints goes to stderr, whatever it raises (even
    SystemExit) or returns that is not a list is recorded against its plugin and it
    contributes nothing, so one broken plugin never stops the others. Ctrl-C is obeyed."""

    def __init__(self, manager: "PluginManager", plugin: str, hook: str, function: Callable):
        self.manager, self.plugin, self.hook, self.function = manager, plugin, hook, function
        self.__name__ = getattr(function, "__name__", hook)

    def __call__(self, *args: Any) -> Contribution | None:
        info = self.manager._infos.setdefault(self.plugin, PluginInfo(name=self.plugin))
        try:
            with _plugin_output():
                items = _items(self.function(*args))
        except KeyboardInterrupt:
            raise  # the user's stop, obeyed (not recorded against the plugin)
        except TypeError as exc:
            if str(exc).startswith("returned "):
                info.errors.append(f"hook {self.hook} {exc}; ignored")
            else:
                info.errors.append(f"hook {self.hook} raised TypeError: {exc}")
            return None
        except BaseException as exc:  # noqa: BLE001 - isolate the broken plugin (sys.exit too)
            info.errors.append(f"hook {self.hook} raised {type(exc).__name__}: {exc}")
            return None
        return Contribution(self.plugin, tuple(items))


class PluginManager:
    """Finds plugins and caches their contributions per kind."""

    def __init__(self, *, load_entry_points: bool = True, disabled: Iterable[str] | None = None,
                 builtins_only: bool | None = None):
        self._pm = pluggy.PluginManager(hookspecs.PROJECT)
        self._pm.add_hookspecs(hookspecs)
        self._infos: dict[str, PluginInfo] = {}
        self._cache: dict[str, dict[str, Any]] = {}
        self._registries: Registries | None = None
        self._runtime: set[str] = set()  # plugins registered by code, not by entry points
        self._reported: set[tuple[str, str]] = set()
        self._lock = threading.RLock()
        self.disabled = set(disabled) if disabled is not None else _env_names(os.environ.get(DISABLE_ENV))
        self.builtins_only = _env_flag(os.environ.get(NO_PLUGINS_ENV)) if builtins_only is None else builtins_only
        self.app = Application(self)
        if load_entry_points:
            self._load_entry_points()

    # -- loading -------------------------------------------------------------------------
    def _load_entry_points(self) -> None:
        found = set()
        for ep in sorted(md.entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name):
            if ep.name in self._infos:  # the same plugin installed twice (e.g. editable + wheel)
                continue
            dist = getattr(ep, "dist", None)
            dist_name = dist.metadata["Name"] if dist is not None else ""
            info = PluginInfo(name=ep.name, distribution=dist_name or "",
                              version=dist.version if dist is not None else "", module=ep.value,
                              builtin=dist_name == BUILTIN_DISTRIBUTION)
            self._infos[ep.name] = info
            found.add(ep.name)
            if ep.name in self.disabled or (self.builtins_only and not info.builtin):
                info.disabled = True
                continue
            try:
                with _plugin_output():
                    obj = ep.load()
            except KeyboardInterrupt:
                raise  # Ctrl-C (or SIGTERM) while importing: the user's stop, obeyed
            except BaseException as exc:  # noqa: BLE001 - any import failure (even sys.exit) is the plugin's
                info.errors.append(f"failed to load {ep.value!r}: {type(exc).__name__}: {exc}")
                continue
            try:
                self._pm.register(obj, name=ep.name)
            except Exception as exc:  # noqa: BLE001 - e.g. a hook with a wrong signature
                info.errors.append(f"failed to register: {type(exc).__name__}: {exc}")
                continue
            self._guard(obj, ep.name)
        for name in sorted(self.disabled - found):
            self._infos[name] = PluginInfo(name=name, disabled=True, errors=[
                f"{DISABLE_ENV} names {name!r}, but no plugin of that name is installed"])

    def register(self, plugin: object, name: str, *, version: str = "") -> None:
        """Register a plugin object at run time (tests, notebooks). Clears the caches."""
        with self._lock:
            self._pm.register(plugin, name=name)
            self._guard(plugin, name)
            self._runtime.add(name)
            self._infos[name] = PluginInfo(name=name, version=version,
                                           module=getattr(plugin, "__name__", type(plugin).__name__))
            self._clear()

    def unregister(self, name: str) -> None:
        with self._lock:
            plugin = self._pm.get_plugin(name)
            if plugin is not None:
                self._pm.unregister(plugin)
            self._runtime.discard(name)
            self._infos.pop(name, None)
            self._clear()

    def _clear(self) -> None:
        self._cache.clear()
        self._registries = None
        for info in self._infos.values():  # recomputed on the next collection
            info.provides.clear()
            info.errors[:] = [e for e in info.errors if e.startswith(("failed to", DISABLE_ENV))]

    # -- collecting ----------------------------------------------------------------------
    def _guard(self, plugin: object, name: str) -> None:
        """Wrap each of the plugin's hook implementations (not its hook wrappers) in a guard."""
        for caller in self._pm.get_hookcallers(plugin) or ():
            for impl in caller.get_hookimpls():
                if impl.plugin is plugin and not (impl.hookwrapper or getattr(impl, "wrapper", False)) \
                        and not isinstance(impl.function, _GuardedHook):
                    impl.function = _GuardedHook(self, name, caller.name, impl.function)

    def _call(self, kind: _Kind) -> list[tuple[PluginInfo, list]]:
        """Every hook implementation's items, in pluggy's call order, validated. The hook is
        called through pluggy (so `tryfirst`/`trylast` and hook wrappers apply), with the one
        Application as `app`; each implementation runs inside its guard (_GuardedHook)."""
        hook = getattr(self._pm.hook, kind.hook)
        out = []
        try:
            results = hook(app=self.app)
        except KeyboardInterrupt:
            raise
        except BaseException as exc:  # noqa: BLE001 - a hook wrapper broke: name the hook
            raise PluginError(f"hook {kind.hook}: a hook wrapper failed: {type(exc).__name__}: "
                              f"{exc}") from None
        for contribution in results:
            if not isinstance(contribution, Contribution):  # a wrapper added a raw result
                contribution = Contribution("a hook wrapper", tuple(_items(contribution)))
            info = self._infos.setdefault(contribution.plugin, PluginInfo(name=contribution.plugin))
            items = list(contribution.items)
            good = []
            for item in items:
                problem = _problem(item, kind)
                if problem is not None:
                    info.errors.append(f"hook {kind.hook} returned {problem}; ignored")
                    continue
                if hasattr(item, "plugin") and not getattr(item, "plugin"):
                    try:
                        item = replace(item, plugin=info.name)
                    except TypeError:
                        pass
                if isinstance(item, ConstraintSpec) and item.check is not None and not info.builtin:
                    item = replace(item, check=GuardedConstraint(info.name, item.name, item.check))
                if isinstance(item, FunctionSpec) and item.impl is not None and not info.builtin:
                    item = replace(item, impl=GuardedFunction(info.name, item.name, item.impl))
                good.append(item)
            out.append((info, good))
        return out

    def _collect(self, name: str) -> dict[str, Any]:
        kind = KINDS[name]
        with self._lock:
            if name in self._cache:
                return self._cache[name]
            calls = self._call(kind)
            found: dict[str, Any] = {}
            owner: dict[str, PluginInfo] = {}
            # built-ins first: whatever order pluggy calls them in, they are never replaced
            for info, items in sorted(calls, key=lambda c: not c[0].builtin):
                for item in items:
                    key = kind.key(item)
                    if key in found:
                        first = owner[key]
                        if first.builtin and not info.builtin:
                            info.errors.append(f"{kind.label} {key!r} is a built-in of grammarkit (plugin "
                                               f"{first.name!r}) and cannot be replaced; ignored")
                        else:
                            info.errors.append(f"{kind.label} {key!r} is also provided by plugin "
                                               f"{first.name!r}, which is used; this one is ignored")
                            first.errors.append(f"{kind.label} {key!r} is also provided by plugin "
                                                f"{info.name!r} (ignored; pluggy's call order decides)")
                        continue
                    found[key] = item
                    owner[key] = info
                    info.provides.setdefault(kind.label, []).append(key)
            self._cache[name] = found
            return found

    def operations(self) -> dict[str, OperationSpec]:
        return self._collect("operations")

    def functions(self) -> dict[str, FunctionSpec]:
        return self._collect("functions")

    def constraints(self) -> dict[str, ConstraintSpec]:
        return self._collect("constraints")

    def backends(self) -> dict[str, BackendSpec]:
        return self._collect("backends")

    def exporters(self) -> dict[str, ExporterSpec]:
        return self._collect("exporters")

    def cli_commands(self) -> dict[str, Any]:
        return self._collect("cli_commands")

    def fits(self) -> dict[str, FitSpec]:
        return self._collect("fits")

    def train_commands(self) -> dict[str, Any]:
        return self._collect("train_commands")

    def registries(self) -> Registries:
        """What the plugins provide, as the core receives it; each kind loads on first use.
        The same object until a plugin is registered or unregistered (so caches keyed by it,
        such as compiled grammars, are reused)."""
        with self._lock:
            if self._registries is None:
                self._registries = Registries({k: getattr(self, k) for k in Registries.KINDS},
                                              rebuild=None if self._runtime else default_registries)
            return self._registries

    def backend(self, name: str) -> BackendSpec:
        backends = self.backends()
        if name not in backends:
            known = ", ".join(sorted(backends)) or "none"
            raise PluginError(f"unknown back end {name!r}; known back ends: {known}")
        return backends[name]

    def default_backend(self, family: str) -> BackendSpec | None:
        for spec in self.backends().values():
            if family in spec.default_for:
                return spec
        return None

    def plugins(self) -> list[PluginInfo]:
        """Every plugin with what it provides and any error, collecting all kinds first."""
        for kind in KINDS:
            self._collect(kind)
        with self._lock:
            self._reported.update((i.name, e) for i in self._infos.values() for e in i.errors)
        return sorted(self._infos.values(), key=lambda i: i.name)

    def new_errors(self) -> list[PluginError]:
        """Errors of the kinds collected so far that were not reported yet (the CLI prints them
        as warnings once per command)."""
        with self._lock:
            out = []
            for info in sorted(self._infos.values(), key=lambda i: i.name):
                for err in info.errors:
                    if (info.name, err) not in self._reported:
                        self._reported.add((info.name, err))
                        out.append(PluginError(f"plugin {info.name!r}: {err}"))
            return out


_manager: PluginManager | None = None
_manager_lock = threading.Lock()


def get_plugin_manager() -> PluginManager:
    """The process-wide plugin manager (entry points loaded once)."""
    global _manager
    with _manager_lock:
        if _manager is None:
            _manager = PluginManager()
        return _manager


def default_registries() -> Registries:
    """The process-wide plugin manager's registries: what the public API functions use when
    they are given none. The core never calls this (tests/core/test_registry_edges.py)."""
    return get_plugin_manager().registries()


# Diagnostics that a third-party plugin could resolve (it may provide the name).
NEEDS_PLUGINS = frozenset({"unknown-operation", "unknown-function", "unknown-constraint"})
_builtin_manager: PluginManager | None = None


def builtin_registries() -> Registries:
    """The registries of grammarkit's own entry points only: no third-party plugin is imported.
    `grammarkit check` uses them first, so that checking a grammar that needs no plugin never
    runs plugin code (a plugin whose import hangs or exits cannot break it)."""
    global _builtin_manager
    with _manager_lock:
        if _builtin_manager is None:
            _builtin_manager = PluginManager(builtins_only=True)
        return _builtin_manager.registries()


def third_party_plugins() -> list[str]:
    """Names of the installed, enabled entry points that are not grammarkit's own (no import),
    and of those GRAMMARKIT_DISABLE_PLUGINS names (loading the manager reports unknown ones)."""
    if _env_flag(os.environ.get(NO_PLUGINS_ENV)):
        return []
    disabled = _env_names(os.environ.get(DISABLE_ENV))
    if disabled:
        return sorted(disabled)
    out = []
    for ep in md.entry_points(group=ENTRY_POINT_GROUP):
        dist = getattr(ep, "dist", None)
        if (dist is None or dist.metadata["Name"] != BUILTIN_DISTRIBUTION) and ep.name not in disabled:
            out.append(ep.name)
    return sorted(set(out))


def reset_plugin_manager() -> None:
    """Forget the cached manager (tests that install plugins at run time use this)."""
    global _manager, _builtin_manager
    with _manager_lock:
        _manager = None
        _builtin_manager = None


def manager_if_loaded() -> PluginManager | None:
    """The process-wide manager if something has created it (the CLI reports its errors)."""
    return _manager


def iter_errors(infos: Iterable[PluginInfo]) -> Iterable[PluginError]:
    for info in infos:
        for err in info.errors:
            yield PluginError(f"plugin {info.name!r}: {err}")
