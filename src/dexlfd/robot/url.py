"""Robot addresses: ``mujoco`` (the simulated Panda) or ``franka://HOST`` (an arm over FCI)."""

from __future__ import annotations

import ipaddress
import re

from dexlfd.errors import InvalidInput

__all__ = ["FRANKA_SCHEME", "parse_robot_url"]

FRANKA_SCHEME = "franka://"
_HOST_RE = re.compile(
    r"^(?=.{1,253}$)[A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?(\.[A-Za-z0-9-]+)*$"
)


def parse_robot_url(url: str) -> str:
    """Host of a ``franka://HOST`` robot address (an IPv4 address or a host name).

    Raises
    ------
    InvalidInput
        If ``url`` is not of that form (the message names the "robot URL").
    """
    if not isinstance(url, str) or not url.startswith(FRANKA_SCHEME):
        raise InvalidInput(
            f"robot URL must be 'mujoco' or 'franka://HOST', got {url!r}", param="robot"
        )
    host = url[len(FRANKA_SCHEME) :].rstrip("/")
    try:
        ipaddress.IPv4Address(host)
        return host
    except ValueError:
        pass
    if not _HOST_RE.match(host) or host.replace(".", "").isdigit():
        raise InvalidInput(
            f"robot URL franka://HOST needs an IPv4 address or host name, got {host!r} in {url!r}",
            param="robot",
        )
    return host
