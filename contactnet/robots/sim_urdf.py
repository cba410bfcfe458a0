"""The URDF the simulators load, written once from a robot's own (``Robot.pybullet_urdf``): mesh paths made
absolute, the robot's collision recipe applied (balls for feet), and a negligible inertia for a link without one;
cached under a name that hashes everything that makes it, the code that writes it included."""

from __future__ import annotations

import hashlib
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from contactnet.atomic import atomic_write_bytes
from contactnet.paths import default_cache_dir


def write_pybullet_urdf(spec: Any, files: Any, cache_dir: Path | None = None, sphere_feet: bool = True) -> Path:
    """Write (once) the URDF variant PyBullet simulates, and return its path (``spec`` a
    `contactnet.robots.description.RobotSpec`, ``files`` its `RobotFiles`: not imported here, which imports this).

    Changes against the shipped URDF: mesh paths are absolute (a copy elsewhere cannot resolve
    ``package://``); with ``sphere_feet`` (the default) the robot's ``collision_recipe`` replaces
    collision shapes (typically the feet become balls of ``foot_radius_m``: mesh feet simulate about
    half as fast). The file name carries a hash of the source, of the recipe's version and of the folder the mesh
    paths point into, so a new example-robot-data version, a new recipe or another installation (another virtual
    environment sharing the cache) makes a new file; a cached file whose meshes are gone (its environment was
    deleted) is written again; writes are atomic. The hash also covers the code that writes the file (this
    function, its helpers and the recipe's source), so a changed writer never reuses an old file.

    A link without an ``<inertial>`` block (pinocchio: no mass) gets a negligible one (`NEGLIGIBLE_MASS_KG`): left
    out, PyBullet would give it 1 kg and MuJoCo a mass from its geometry, and the simulated robot would not be the
    model.
    """
    source = files.urdf.read_bytes()
    recipe = f"{spec.name}-{'sphere' if sphere_feet else 'mesh'}-feet-{spec.recipe_version}".encode()
    digest = hashlib.sha256(source + recipe + str(files.package_root.resolve()).encode()
                            + _writer_source(spec)).hexdigest()[:12]
    kind = "spherefeet" if sphere_feet else "meshfeet"
    out = (cache_dir or default_cache_dir()) / "urdf" / f"{spec.name}_{kind}_{digest}.urdf"
    if out.is_file() and _meshes_exist(out):
        return out
    root = ET.fromstring(source)
    for mesh in root.iter("mesh"):
        filename = mesh.get("filename", "")
        if filename.startswith("package://"):
            mesh.set("filename", str(files.package_root / filename[len("package://"):]))
        elif filename.startswith("file://"):
            mesh.set("filename", filename[len("file://"):])
        elif filename and not Path(filename).is_absolute():  # relative to the URDF: absolute in the cached copy
            mesh.set("filename", str(files.urdf.parent / filename))
    _add_missing_inertia(root)
    if sphere_feet and spec.collision_recipe is not None:
        for link in root.iter("link"):
            replacement = spec.collision_recipe(link.get("name", ""))
            if replacement is None:
                continue
            if isinstance(replacement, list):  # the link's collisions, all of them
                for collision in link.findall("collision"):
                    link.remove(collision)
                for shape, xyz, rpy in replacement:
                    _set_collision(ET.SubElement(link, "collision"), shape, xyz, rpy)
                continue
            collision = link.find("collision")
            if collision is None:
                collision = ET.SubElement(link, "collision")
            _set_collision(collision, *replacement)
    atomic_write_bytes(out, ET.tostring(root, xml_declaration=True, encoding="utf-8"))
    return out


#: The mass given to a URDF link that has none (pinocchio's zero), kg; its inertia is that of a 1 cm ball of it.
NEGLIGIBLE_MASS_KG = 1e-6


def links_without_inertia(root: ET.Element) -> list[str]:
    """The names of the URDF links (``root``: the ``<robot>`` element) that have no ``<inertial>`` block."""
    return [link.get("name", "?") for link in root.iter("link") if link.find("inertial") is None]


def _add_missing_inertia(root: ET.Element) -> None:
    inertia = f"{0.4 * NEGLIGIBLE_MASS_KG * 0.01 ** 2:.3g}"
    for link in root.iter("link"):
        if link.find("inertial") is None:
            inertial = ET.SubElement(link, "inertial")
            ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
            ET.SubElement(inertial, "mass", value=f"{NEGLIGIBLE_MASS_KG:g}")
            ET.SubElement(inertial, "inertia", ixx=inertia, ixy="0", ixz="0", iyy=inertia, iyz="0", izz=inertia)


def _writer_source(spec: Any) -> bytes:
    """The source of the code that writes a robot's simulated URDF (part of the cached file's key)."""
    import inspect

    parts = [write_pybullet_urdf, _add_missing_inertia, _set_collision]
    recipe = spec.collision_recipe
    if recipe is not None:  # a function, or an object whose class says what it does and whose repr its numbers
        parts += [recipe] if inspect.isfunction(recipe) else [type(recipe)]
    text = [] if recipe is None or inspect.isfunction(recipe) else [repr(recipe)]
    for part in parts:
        try:
            text.append(inspect.getsource(part))
        except (OSError, TypeError):  # no source (e.g. built in a REPL): its qualified name
            text.append(getattr(part, "__qualname__", repr(part)))
    return "\n".join(text).encode()


def _meshes_exist(urdf: Path) -> bool:
    """Every mesh file a (generated) URDF names exists; False also for a file that does not parse."""
    try:
        root = ET.parse(urdf).getroot()
    except (OSError, ET.ParseError):
        return False
    return all((urdf.parent / mesh.get("filename", "")).is_file() for mesh in root.iter("mesh"))


def _set_collision(collision: ET.Element, shape: ET.Element, xyz: str, rpy: str = "0 0 0") -> None:
    origin = collision.find("origin")
    if origin is None:
        origin = ET.SubElement(collision, "origin")
    origin.set("xyz", xyz)
    origin.set("rpy", rpy)
    geometry = collision.find("geometry")
    if geometry is None:
        geometry = ET.SubElement(collision, "geometry")
    for child in list(geometry):
        geometry.remove(child)
    geometry.append(shape)


__all__ = ["NEGLIGIBLE_MASS_KG", "links_without_inertia", "write_pybullet_urdf"]
