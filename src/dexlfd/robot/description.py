"""The Panda's MuJoCo description, converted at run time from franka_ros's URDF.

The URDF with identified inertial parameters is franka_ros's
``franka_description`` (Apache-2.0, (c) Franka Emika GmbH), as packaged by
``example-robot-data`` 6.0.0; it ships inside dexlfd (``dexlfd/data/panda``:
the URDF unchanged, the collision ``.stl`` meshes and the licence; the visual
``.dae`` meshes, which the conversion drops, are left out). MuJoCo reads URDF
after three edits made here: ``package://`` paths become files, the visual
``.dae`` meshes (which MuJoCo cannot read) are dropped in favour of the
collision ``.stl`` meshes, and a ``<mujoco><compiler .../></mujoco>`` element
keeps every body (no fusing of static links, so the flange and hand frames stay
addressable). The converted text is cached per process (conversion ~10 ms).
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

from dexlfd.errors import InvalidFile

__all__ = ["panda_description_dir", "panda_urdf_text"]

_PACKAGE = "package://example-robot-data/robots/panda_description/"
_COMPILER = (
    '<mujoco><compiler strippath="false" fusestatic="false" discardvisual="false"/></mujoco>'
)


def panda_description_dir() -> Path:
    """Folder of the packaged franka_ros Panda description (URDF, collision meshes, LICENSE)."""
    from importlib import resources

    root = resources.files("dexlfd.data") / "panda"
    if not isinstance(root, Path) or not (root / "urdf" / "panda.urdf").is_file():
        raise InvalidFile(
            f"the Panda description is missing from the installed dexlfd.data package ({root})"
        )
    return root


@functools.lru_cache(maxsize=4)
def panda_urdf_text(fixed_fingers: bool = False) -> str:
    """URDF text of the Panda ready for ``mujoco.MjSpec.from_string``.

    Parameters
    ----------
    fixed_fingers : bool
        Turn the two prismatic finger joints into fixed joints (an arm-only
        model with 7 degrees of freedom, as a controller's model).
    """
    root = panda_description_dir()
    path = root / "urdf" / "panda.urdf"
    try:
        txt = path.read_text()
    except OSError as exc:  # pragma: no cover - the wheel is broken
        raise InvalidFile(f"{path}: cannot read the Panda URDF: {exc}") from exc
    txt = re.sub(r"<visual>.*?</visual>", "", txt, flags=re.S)
    txt = txt.replace(_PACKAGE, f"{root}/")
    txt, n = re.subn(r"<robot name=\"panda\"[^>]*>", f'<robot name="panda">{_COMPILER}', txt)
    if n != 1:
        raise InvalidFile(f'{path}: unexpected URDF layout (no <robot name="panda">)')
    if fixed_fingers:
        txt = re.sub(r"<mimic[^>]*/>", "", txt)
        txt = txt.replace('type="prismatic"', 'type="fixed"')
    return txt
