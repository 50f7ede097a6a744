"""What each topic of a bag is decoded with.

In order: the definition the bag embeds (MCAP, sqlite3 from ROS 2 Iron on) is what its writer
used; else the user's (`--msg TYPE=FILE`, a map's [msg] table); else, for the research group's
types, every version of their .msg history (robominer.py), the one the bag's bytes fit; else
ROS 2 Humble's standard types. A version fits a message when it decodes it and uses it up to
its CDR padding (at most 3 bytes left): a definition with a field too many reads past the end,
one with a field too few leaves 4 or more bytes. The version that fits the most of the topic's
first messages (more than half of them) wins; of several, the one leaving the fewest bytes; a
tie goes to the newest and is said.
"""

from __future__ import annotations

from rosbags.interfaces import MessageDefinitionFormat, Nodetype
from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore
from rosbags.typesys.base import TypesysError

from . import InputError
from .limits import read_text_file
from .robominer import VERSIONS

HEADER = "std_msgs/msg/Header"


def parse_msg_option(text: str) -> tuple[str, str]:
    """`--msg TYPE=FILE` -> (type name, .msg text)."""
    from .mapping import _type_name  # the map's rule for type names
    typ, sep, path = text.partition("=")
    if not sep or not path:
        raise InputError("--msg %s: give TYPE=FILE, e.g. --msg robominer_msgs/msg/MotorModuleFeedback=old.msg" % text)
    return _type_name("--msg", typ, typ), read_text_file(path, ".msg file")


def _parse(text: str, typ: str, source: str) -> dict:
    try:
        return get_types_from_msg(text, typ)
    except (TypesysError, IndexError, ValueError) as e:
        raise InputError("%s: the definition of %s cannot be parsed: %s" % (source, typ, e)) from None


def _embedded(path, c) -> dict:
    try:
        if c.msgdef.format == MessageDefinitionFormat.MSG:
            return get_types_from_msg(c.msgdef.data, c.msgtype)
        if c.msgdef.format == MessageDefinitionFormat.IDL:
            # one IDL, or several each after a line of 80 '=' and "IDL: name"
            defs = {}
            sep = "=" * 80 + "\n"
            parts = c.msgdef.data.split(sep)[1:] if c.msgdef.data.startswith(sep) else [c.msgdef.data]
            for part in parts:
                defs.update(get_types_from_idl(part.split("\n", 1)[1] if part.startswith("IDL: ") else part))
            return defs
    except (TypesysError, IndexError, ValueError) as e:
        raise InputError("%s: topic %s: its type %s has a definition the reader cannot parse: %s"
                         % (path, c.topic, c.msgtype, e)) from None
    return {}


def _store(defs: dict):
    store = get_typestore(Stores.EMPTY)
    store.register(defs)
    return store


def _leftover(store, typ: str, raw: bytes) -> int | None:
    """Bytes left after decoding raw as typ (None: it does not decode)."""
    if len(raw) < 4 or bytes(raw[:2]) not in (b"\x00\x00", b"\x00\x01"):
        return None
    msgdef = store.get_msgdef(typ)
    func = msgdef.deserialize_cdr_le if raw[1] else msgdef.deserialize_cdr_be
    try:
        _, pos = func(memoryview(raw)[4:], 0, msgdef.cls, store)
    except Exception:  # rosbags: SerdeError, struct.error, ... on bytes of another type
        return None
    left = len(raw) - 4 - pos
    return left if left >= 0 else None


class Decoder:
    """One connection's type: its typestore, where the definition came from, its field tree."""

    def __init__(self, store, msgtype: str, source: str):
        self.store, self.msgtype, self.source = store, msgtype, source

    def decode(self, raw):
        return self.store.deserialize_cdr(raw, self.msgtype)

    def fields(self, typ=None) -> dict:
        return dict(self.store.fielddefs[typ or self.msgtype][1])

    def has_header(self) -> bool:
        f = self.store.fielddefs[self.msgtype][1]
        return bool(f) and f[0][0] == "header" and f[0][1] == (Nodetype.NAME, HEADER)


class TypeBook:
    """The definitions of a bag's mapped connections, and the choice per connection."""

    def __init__(self, path: str, connections, user: dict[str, tuple[str, str]], warn):
        """user: type -> (where it came from, .msg text)."""
        self.path = path
        embedded: dict = {}
        self.embedded_types = set()
        for c in connections:
            d = _embedded(path, c)
            if d:
                self.embedded_types.add(c.msgtype)
                embedded.update(d)
        user_defs: dict = {}
        self.user_source = {}
        for typ, (source, text) in user.items():
            if typ in self.embedded_types:
                warn("%s: the bag carries its own definition of %s; %s is not used for it" % (path, typ, source))
                continue
            user_defs.update(_parse(text, typ, source))
            self.user_source[typ] = source
        self.base = dict(get_typestore(Stores.ROS2_HUMBLE).fielddefs)
        for name, versions in VERSIONS.items():
            self.base.update(get_types_from_msg(versions[0][1], name))
        self.base.update(user_defs)
        self.base.update(embedded)
        self._base_store = _store(self.base)
        self._version_stores: dict[tuple[str, int], object] = {}

    def candidates(self, msgtype: str) -> list[Decoder]:
        """Every definition the connection may be decoded with, in order of preference."""
        if msgtype in self.embedded_types:
            return [Decoder(self._base_store, msgtype, "the bag's definition")]
        if msgtype in self.user_source:
            return [Decoder(self._base_store, msgtype, self.user_source[msgtype])]
        if msgtype in VERSIONS:
            out = []
            for i, (label, text) in enumerate(VERSIONS[msgtype]):
                key = (msgtype, i)
                if key not in self._version_stores:
                    defs = dict(self.base)
                    defs.update(get_types_from_msg(text, msgtype))
                    self._version_stores[key] = self._base_store if i == 0 else _store(defs)
                out.append(Decoder(self._version_stores[key], msgtype, "%s %s" % (msgtype.rsplit("/", 1)[1], label)))
            return out
        if msgtype in self.base:
            return [Decoder(self._base_store, msgtype, "ROS 2's standard definition")]
        return []

    def choose(self, topic: str, msgtype: str, samples: list[bytes]) -> tuple[Decoder | None, str, str | None]:
        """(decoder, why not when None, a note when the choice was close)."""
        cands = self.candidates(msgtype)
        if not cands:
            return None, ("its type %s is neither defined in the bag nor given with --msg %s=FILE, nor a standard "
                          "ROS 2 or robominer_msgs type" % (msgtype, msgtype)), None
        if len(cands) == 1:
            return cands[0], "", None  # nothing to choose: a message that does not decode is named later
        scored = []
        for d in cands:
            lefts = [_leftover(d.store, msgtype, raw) for raw in samples]
            ok = [x for x in lefts if x is not None and x <= 3]
            scored.append((len(ok), -max(ok, default=0), d, lefts))
        n_best = max(s[0] for s in scored)
        if 2 * n_best <= len(samples):
            sizes = sorted({len(r) for r in samples})
            return None, ("its messages (%s bytes) fit none of %s (give the definition the bag was recorded with: "
                          "--msg %s=FILE)" % ("/".join(map(str, sizes[:4])), "; ".join(d.source for d in cands),
                                              msgtype)), None
        fits = [(-s[1], s[2]) for s in scored if s[0] == n_best]
        best = min(x for x, _ in fits)
        tied = [d for x, d in fits if x == best]
        note = None
        if len(tied) > 1:
            note = ("its messages fit %s and %s equally; decoded as the first (--msg %s=FILE to say which)"
                    % (tied[0].source, ", ".join(d.source for d in tied[1:]), msgtype))
        elif len(cands) > 1 and tied[0] is not cands[0]:
            note = "decoded as %s" % tied[0].source
        return tied[0], "", note
