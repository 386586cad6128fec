"""Opening the Zenoh session of the face: peer mode, endpoints, scouting, the loopback rule.

The only module of :mod:`robodcn.zenoh` that builds a Zenoh configuration; ``zenoh`` (the
``eclipse-zenoh`` package, the ``zenoh`` extra) is imported here when a session opens, so
``import robodcn`` and planning never need it.
"""

from __future__ import annotations

import json
from typing import Any

from robodcn.errors import InputError
from robodcn.zenoh.options import DEFAULT_LISTEN, ZenohOptions, check_listen

#: Zenoh's own default listen endpoints of a peer (every interface): replaced by loopback.
_ZENOH_DEFAULT_LISTEN = ({"router": ["tcp/[::]:7447"], "peer": ["tcp/[::]:0"]}, [])


def zenoh_module() -> Any:
    """The ``zenoh`` package, or InputError saying how to install it."""
    try:
        import zenoh
    except ImportError:
        raise InputError("the Zenoh face needs the zenoh extra: pip install 'robodcn[zenoh]' "
                         "(eclipse-zenoh)", field="--zenoh", value=None) from None
    return zenoh


def _get(config: Any, key: str) -> Any:
    try:
        return json.loads(config.get_json(key))
    except Exception:  # an unset or unknown key reads as absent
        return None


def build_config(options: ZenohOptions, *, listen_default: tuple[str, ...] = DEFAULT_LISTEN
                 ) -> Any:
    """The Zenoh configuration of ``options`` (the config file under them), with the listen
    endpoints checked by :func:`robodcn.zenoh.options.check_listen`."""
    zenoh = zenoh_module()
    if options.config_file is not None:
        try:
            config = zenoh.Config.from_file(options.config_file)
        except Exception as exc:
            raise InputError(f"--zenoh-config {options.config_file!r}: {exc}",
                             field="--zenoh-config", value=options.config_file) from None
    else:
        config = zenoh.Config()
    if _get(config, "mode") in (None, "peer"):
        config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", json.dumps(options.scout))
    # timestamps on every sample: the transient-local publishers (zenoh-ext) need them, as
    # rmw_zenoh's sessions have them
    config.insert_json5("timestamping/enabled", "true")
    listen = options.listen
    if not listen:
        configured = _get(config, "listen/endpoints")
        listen = listen_default if configured in _ZENOH_DEFAULT_LISTEN else tuple(
            configured.get("peer", []) if isinstance(configured, dict) else configured)
    usrpwd = _get(config, "transport/auth/usrpwd") or {}
    tls = _get(config, "transport/link/tls") or {}
    check_listen(tuple(listen), usrpwd=bool(usrpwd.get("user") and usrpwd.get("password")),
                 tls=bool(tls.get("listen_certificate") and tls.get("listen_private_key")))
    config.insert_json5("listen/endpoints", json.dumps(list(listen)))
    if options.connect:
        config.insert_json5("connect/endpoints", json.dumps(list(options.connect)))
    return config


def open_session(options: ZenohOptions) -> Any:
    """An open ``zenoh.Session`` for ``options`` (close it when done)."""
    zenoh = zenoh_module()
    config = build_config(options)
    try:
        return zenoh.open(config)
    except Exception as exc:
        raise InputError(f"cannot open the Zenoh session: {exc}", field="--zenoh-listen",
                         value=list(options.listen)) from None
