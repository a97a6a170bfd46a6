"""The plugin manager: loads entry points of group ``grammarkit`` and collects what they provide.

Each hook implementation is called on its own so that a broken plugin is reported with its
name and skipped, and everything else keeps working (`grammarkit plugins` lists the failure).
"""
from __future__ import annotations

import importlib.metadata as md
import threading
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Iterable

import pluggy

from . import hookspecs
from .errors import PluginError
from .registry import BackendSpec, ConstraintSpec, ExporterSpec, FunctionSpec, OperationSpec, Registries

ENTRY_POINT_GROUP = "grammarkit"


@dataclass
class PluginInfo:
    name: str
    distribution: str = ""
    version: str = ""
    module: str = ""
    provides: dict[str, list[str]] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.errors


class PluginManager:
    """Finds plugins and caches their contributions per kind."""

    def __init__(self, *, load_entry_points: bool = True):
        self._pm = pluggy.PluginManager(hookspecs.PROJECT)
        self._pm.add_hookspecs(hookspecs)
        self._infos: dict[str, PluginInfo] = {}
        self._cache: dict[str, dict[str, Any]] = {}
        self._lock = threading.RLock()
        if load_entry_points:
            self._load_entry_points()

    # -- loading -------------------------------------------------------------------------
    def _load_entry_points(self) -> None:
        for ep in sorted(md.entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name):
            dist = getattr(ep, "dist", None)
            info = PluginInfo(
                name=ep.name,
                distribution=dist.metadata["Name"] if dist is not None else "",
                version=dist.version if dist is not None else "",
                module=ep.value,
            )
            if ep.name in self._infos:  # the same plugin installed twice (e.g. editable + wheel)
                continue
            self._infos[ep.name] = info
            try:
                obj = ep.load()
            except Exception as exc:  # noqa: BLE001 - any import failure is the plugin's
                info.errors.append(f"failed to load {ep.value!r}: {type(exc).__name__}: {exc}")
                continue
            try:
                self._pm.register(obj, name=ep.name)
            except Exception as exc:  # noqa: BLE001 - e.g. a hook with a wrong signature
                info.errors.append(f"failed to register: {type(exc).__name__}: {exc}")

    def register(self, plugin: object, name: str, *, version: str = "") -> None:
        """Register a plugin object at run time (tests, notebooks). Clears the caches."""
        with self._lock:
            self._pm.register(plugin, name=name)
            self._infos[name] = PluginInfo(name=name, version=version,
                                           module=getattr(plugin, "__name__", type(plugin).__name__))
            self._cache.clear()

    def unregister(self, name: str) -> None:
        with self._lock:
            plugin = self._pm.get_plugin(name)
            if plugin is not None:
                self._pm.unregister(plugin)
            self._infos.pop(name, None)
            self._cache.clear()

    # -- collecting ----------------------------------------------------------------------
    def _collect(self, hook_name: str, key: Callable[[Any], str], kind: str) -> dict[str, Any]:
        with self._lock:
            if kind in self._cache:
                return self._cache[kind]
            found: dict[str, Any] = {}
            hook = getattr(self._pm.hook, hook_name)
            # get_hookimpls() is in registration order (pluggy *calls* them in reverse); the
            # first registered provider of a name wins, so entry points load sorted by name.
            for impl in hook.get_hookimpls():
                plugin_name = impl.plugin_name
                info = self._infos.setdefault(plugin_name, PluginInfo(name=plugin_name))
                try:
                    items = list(impl.function() or ())
                except Exception as exc:  # noqa: BLE001 - isolate the broken plugin
                    info.errors.append(f"hook {hook_name} raised {type(exc).__name__}: {exc}")
                    continue
                for item in items:
                    name = key(item)
                    if hasattr(item, "plugin") and not getattr(item, "plugin"):
                        try:
                            item = replace(item, plugin=plugin_name)
                        except TypeError:
                            pass
                    if name in found:
                        other = getattr(found[name], "plugin", "?")
                        info.errors.append(f"{kind} {name!r} already provided by plugin {other!r}; ignored")
                        continue
                    found[name] = item
                    info.provides.setdefault(kind, []).append(name)
            self._cache[kind] = found
            return found

    def operations(self) -> dict[str, OperationSpec]:
        return self._collect("grammarkit_operations", lambda o: o.name, "operation")

    def functions(self) -> dict[str, FunctionSpec]:
        return self._collect("grammarkit_functions", lambda f: f.name, "function")

    def constraints(self) -> dict[str, ConstraintSpec]:
        return self._collect("grammarkit_constraints", lambda c: c.name, "constraint")

    def backends(self) -> dict[str, BackendSpec]:
        return self._collect("grammarkit_backends", lambda b: b.name, "backend")

    def exporters(self) -> dict[str, ExporterSpec]:
        return self._collect("grammarkit_exporters", lambda e: e.format, "exporter")

    def cli_commands(self) -> dict[str, Any]:
        return self._collect("grammarkit_cli_commands", lambda c: c.name, "command")

    def fits(self) -> dict[str, Any]:
        return self._collect("grammarkit_insert_fits", lambda f: f.name, "fit")

    def train_commands(self) -> dict[str, Any]:
        return self._collect("grammarkit_train_commands", lambda c: c.name, "train command")

    def registries(self) -> "Registries":
        """What the plugins provide, as the core receives it; each kind loads on first use."""
        from .registry import Registries

        return Registries({"operations": self.operations, "functions": self.functions,
                           "constraints": self.constraints, "exporters": self.exporters,
                           "backends": self.backends, "fits": self.fits})

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
        for method in (self.operations, self.functions, self.constraints, self.backends,
                       self.exporters, self.cli_commands, self.train_commands, self.fits):
            method()
        return sorted(self._infos.values(), key=lambda i: i.name)


_manager: PluginManager | None = None
_manager_lock = threading.Lock()


def get_plugin_manager() -> PluginManager:
    """The process-wide plugin manager (entry points loaded once)."""
    global _manager
    with _manager_lock:
        if _manager is None:
            _manager = PluginManager()
        return _manager


def reset_plugin_manager() -> None:
    """Forget the cached manager (tests that install plugins at run time use this)."""
    global _manager
    with _manager_lock:
        _manager = None


def iter_errors(infos: Iterable[PluginInfo]) -> Iterable[PluginError]:
    for info in infos:
        for err in info.errors:
            yield PluginError(f"plugin {info.name!r}: {err}")
