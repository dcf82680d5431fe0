"""lxml plumbing shared by the XML formats (XMLBIF, XBN): safe parsing and located errors."""

from __future__ import annotations

from lxml import etree

from bayesmap.errors import FormatError

_PARSER = etree.XMLParser(
    resolve_entities=False, no_network=True, huge_tree=True, remove_comments=True, remove_pis=True
)


def parse(data: str | bytes, path: str | None) -> etree._Element:
    """Parse XML text or bytes; syntax errors become :class:`FormatError` with their line."""
    if isinstance(data, str):
        data = data.encode("utf-8") if not data.lstrip().startswith("<?xml") else _strip_decl(data)
    try:
        root = etree.fromstring(data, _PARSER)
    except etree.XMLSyntaxError as error:
        line = error.position[0] if error.position else None
        raise FormatError(f"not well-formed XML: {error.msg}", path=path, line=line) from None
    except ValueError as error:
        raise FormatError(f"not XML: {error}", path=path) from None
    _refuse_entities(root, path)
    return root


def _refuse_entities(root: etree._Element, path: str | None) -> None:
    """Refuse entity declarations and references: network files need none, and they are the
    vehicle of entity-expansion and external-entity attacks (the five predefined entities
    and character references are plain text to the parser and stay allowed)."""
    dtd = root.getroottree().docinfo.internalDTD
    declared = [] if dtd is None else [entity.name for entity in dtd.iterentities()]
    if declared:
        raise FormatError(
            f"the document declares entities {declared[:5]}, which network files do not use",
            path=path,
            element="<!DOCTYPE>",
        )
    for entity in root.iter(etree.Entity):
        raise FormatError(
            f"entity reference {entity.text} is not allowed; write the text itself",
            path=path,
            line=entity.sourceline,
        )


def _strip_decl(text: str) -> bytes:
    """A str with an XML declaration, re-encoded as UTF-8 bytes with a matching declaration."""
    end = text.find("?>")
    return ('<?xml version="1.0" encoding="UTF-8"?>' + text[end + 2 :]).encode("utf-8")


def tag(element: etree._Element) -> str:
    """Upper-case local name of an element (tags are matched case-insensitively)."""
    name = element.tag
    if not isinstance(name, str):
        return ""
    return etree.QName(name).localname.upper() if "}" in name else name.upper()


def children(element: etree._Element, name: str) -> list[etree._Element]:
    """Direct children called ``name`` (case-insensitive)."""
    return [child for child in element if tag(child) == name]


def child(element: etree._Element, name: str, path: str | None, owner: str) -> etree._Element:
    """The one direct child called ``name``; :class:`FormatError` if missing or repeated."""
    found = children(element, name)
    if len(found) != 1:
        problem = "no" if not found else f"{len(found)}"
        raise error(
            element, path, f"{owner} has {problem} <{name}> element(s); expected exactly one"
        )
    return found[0]


def text(element: etree._Element) -> str:
    """Text content of ``element`` (including text inside children), stripped."""
    return "".join(element.itertext()).strip()


def attribute(element: etree._Element, name: str, path: str | None, owner: str) -> str:
    """A required attribute (its name matched case-insensitively), stripped."""
    for key, value in element.attrib.items():
        if str(key).upper() == name:
            return str(value).strip()
    raise error(element, path, f"{owner}: <{tag(element)}> lacks the {name} attribute")


def optional_attribute(element: etree._Element, name: str) -> str | None:
    """An attribute matched case-insensitively, or ``None``."""
    for key, value in element.attrib.items():
        if str(key).upper() == name:
            return str(value).strip()
    return None


def error(element: etree._Element, path: str | None, message: str) -> FormatError:
    """A :class:`FormatError` at ``element`` (its line and tag)."""
    return FormatError(message, path=path, line=element.sourceline, element=f"<{tag(element)}>")


def serialise(root: etree._Element) -> str:
    """Pretty XML text with a UTF-8 declaration."""
    etree.indent(root, space="  ")
    body = str(etree.tostring(root, encoding="unicode"))
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + body + "\n"


def sub(
    parent: etree._Element,
    element_name: str,
    content: str | None = None,
    path: str | None = None,
    **attributes: str,
) -> etree._Element:
    """Append a child element; text XML cannot hold raises :class:`FormatError`."""
    try:
        element = etree.SubElement(parent, element_name, attrib=attributes)
        if content is not None:
            element.text = content
    except ValueError as problem:
        raise FormatError(
            f"cannot write {content if content is not None else attributes!r} in XML: {problem}",
            path=path,
        ) from None
    return element
