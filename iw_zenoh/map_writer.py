"""Writing labs and grids as Ciber-Rato / Intellwheels XML (read back by :mod:`iw_zenoh.maps`,
which re-exports these writers)."""

from __future__ import annotations

from lxml import etree

from iw_zenoh.core.lab import Grid, Lab

__all__ = ["grid_to_xml", "lab_to_xml"]


def _fmt(v: float, legacy: bool) -> str:
    return f"{v:g}" if legacy else repr(float(v))


def lab_to_xml(lab: Lab, *, legacy: bool = False) -> bytes:
    """Writes a lab as Lab XML.

    Args:
        lab: The lab.
        legacy: Ciber-Rato's re-serialised form (``%g`` numbers, Height before Width, tabs);
            otherwise numbers are written exactly, so the lab reads back equal.

    Returns:
        The document (UTF-8, no declaration).
    """
    root = etree.Element("Lab")
    root.set("Name", lab.name)
    root.set("Height", _fmt(lab.height_m, legacy))
    root.set("Width", _fmt(lab.width_m, legacy))
    for b in lab.beacons:
        etree.SubElement(root, "Beacon", X=_fmt(b.x, legacy), Y=_fmt(b.y, legacy), Height=_fmt(b.height_m, legacy))
    for t in lab.targets:
        etree.SubElement(root, "Target", X=_fmt(t.x, legacy), Y=_fmt(t.y, legacy), Radius=_fmt(t.radius_m, legacy))
    for w in lab.walls:
        we = etree.SubElement(root, "Wall", Height=_fmt(w.height_m, legacy))
        for x, y in w.corners:
            etree.SubElement(we, "Corner", X=_fmt(x, legacy), Y=_fmt(y, legacy))
    etree.indent(root, space="\t")
    return bytes(etree.tostring(root, encoding="utf-8")) + b"\n"


def grid_to_xml(grid: Grid, *, legacy: bool = False) -> bytes:
    """Writes a grid as Grid XML (see :func:`lab_to_xml` for ``legacy``)."""
    root = etree.Element("Grid")
    for p in grid.positions:
        etree.SubElement(root, "Position", X=_fmt(p.x, legacy), Y=_fmt(p.y, legacy), Dir=_fmt(p.dir_deg, legacy))
    etree.indent(root, space="\t")
    return bytes(etree.tostring(root, encoding="utf-8")) + b"\n"
