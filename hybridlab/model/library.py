"""Network files: their templates, the component libraries they import, their product.

``imports = ["lib/rooms.toml"]`` makes the templates of another file available; paths
are relative to the importing file. An imported file is a network file or a component
library (a file with templates and no instances); its own imports come along, its
instances and scenarios do not. A file imported along two paths is read once; an
import cycle, a template declared in two files, more than :data:`MAX_IMPORTS` files or
more than :data:`~hybridlab._files.MAX_INPUT_BYTES` bytes in all are errors.
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from hybridlab._files import MAX_INPUT_BYTES, read_bounded
from hybridlab.errors import ModelError
from hybridlab.model.compose import SourcedTemplate, check_template, compose
from hybridlab.model.network import Network
from hybridlab.model.schema import Model

__all__ = ["MAX_IMPORTS", "is_network", "network_from_dict"]

#: The most files one model may import, directly or through other imports.
MAX_IMPORTS = 64
#: The top-level keys that make a file a network file (a flat model has none of them).
_NETWORK_KEYS = frozenset({"templates", "instances", "imports"})


def is_network(data: Mapping[str, Any]) -> bool:
    """Whether the data of a model file describes components (else a flat model).

    Examples
    --------
    >>> is_network({"name": "x", "instances": {}}), is_network({"name": "x", "modes": {}})
    (True, False)
    """
    return not _NETWORK_KEYS.isdisjoint(data)


@dataclass
class _Reader:
    """Reads imported files once each, within the bounds."""

    loaded: dict[Path, dict[str, SourcedTemplate]] = field(default_factory=dict)
    size: int = 0

    def network(self, data: Any, source: str) -> Network:
        from hybridlab.model.loader import _from_validation_error

        if not isinstance(data, Mapping):
            raise ModelError("a model must be a table of keys", source=source)
        try:
            return Network.model_validate(dict(data))
        except ValidationError as exc:
            raise _from_validation_error(exc, dict(data)).with_source(source) from None

    def read(self, path: Path, shown: str, key: str, importer: str) -> Network:
        def fail(message: str) -> ModelError:
            return ModelError(message, key=key, token=shown, source=importer)

        if len(self.loaded) >= MAX_IMPORTS:
            raise fail(f"more than {MAX_IMPORTS} imported files")
        try:
            raw = read_bounded(path, MAX_INPUT_BYTES - self.size)
        except OSError as exc:
            raise fail(f"cannot read imported file: {exc.strerror}") from None
        self.size += len(raw)
        try:
            data = tomllib.loads(raw.decode("utf-8"))
        except UnicodeDecodeError:
            raise ModelError("file is not UTF-8 text", source=shown) from None
        except tomllib.TOMLDecodeError as exc:
            raise ModelError(f"invalid TOML: {exc}", source=shown) from None
        if not is_network(data):
            raise fail("an imported file must declare templates (it is a flat model)")
        return self.network(data, shown)

    def templates(self, network: Network, source: str, folder: Path,
                  chain: tuple[Path, ...], shown_chain: tuple[str, ...]
                  ) -> dict[str, SourcedTemplate]:
        out: dict[str, SourcedTemplate] = {}

        def add(name: str, entry: SourcedTemplate, key: str) -> None:
            if name in out and out[name] is not entry:
                raise ModelError(f"template {name!r} is declared in both {out[name].source} "
                                 f"and {entry.source}", key=key, token=name, source=source)
            out[name] = entry

        for k, relative in enumerate(network.imports):
            key = f"imports[{k}]"
            path = (folder / relative).resolve()
            shown = os.path.normpath(os.path.join(os.path.dirname(source), relative))
            if path in chain:
                cycle = [*shown_chain[chain.index(path):], shown]
                raise ModelError("import cycle", key=key, token=" -> ".join(cycle),
                                 source=source)
            if path not in self.loaded:
                imported = self.read(path, shown, key, source)
                self.loaded[path] = self.templates(imported, shown, path.parent,
                                                   (*chain, path), (*shown_chain, shown))
            for name, entry in self.loaded[path].items():
                add(name, entry, key)
        for name, tpl in network.templates.items():
            check_template(name, tpl, source)
            add(name, SourcedTemplate(tpl, source), f"templates.{name}")
        return out


def network_from_dict(data: Mapping[str, Any], *, source: str = "<dict>",
                      path: str | Path | None = None) -> Model:
    """Build the flat product model of a network file's data.

    Parameters
    ----------
    data : mapping
        The file's content (``templates``, ``imports``, ``instances``, ...).
    source : str
        The name errors give the file.
    path : str or pathlib.Path, optional
        The file itself: imports are relative to its folder (else to the current
        folder), and importing it again is a cycle.

    Raises
    ------
    ModelError
        One line naming the file, the key path and the token.

    Examples
    --------
    >>> import tomllib
    >>> with open("models/two_rooms.toml", "rb") as fh:
    ...     data = tomllib.load(fh)
    >>> model = network_from_dict(data, source="two_rooms.toml")
    >>> model.initial.mode, model.network.components[2].template
    ('room1.off|room2.off|heater.idle', 'heater')
    """
    reader = _Reader()
    network = reader.network(data, source)
    here = Path(path).resolve() if path is not None else None
    folder = here.parent if here is not None else Path.cwd()
    chain = (here,) if here is not None else ()
    templates = reader.templates(network, source, folder, chain, (source,) if chain else ())
    product, summary = compose(network, templates, source)
    from hybridlab.model.loader import model_from_dict

    try:
        model = model_from_dict(product, source=source)
    except ModelError as exc:
        raise ModelError(f"in the product of the components: {exc.message}", key=exc.key,
                         token=exc.token, source=source) from None
    model._network = summary
    return model
