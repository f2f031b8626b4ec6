"""Minimal ELF32 little-endian reader for the firmware images: section headers and the
symbol table (name, address, size, section), enough for scripts/cycles (the address
of the trace flag) and scripts/memory (flash, RAM, largest symbols)."""

import struct


class Elf:
    def __init__(self, path):
        with open(path, "rb") as f:
            self.data = f.read()
        d = self.data
        if d[:4] != b"\x7fELF" or d[4] != 1 or d[5] != 1:
            raise ValueError(f"{path}: not a little-endian ELF32 file")
        (self.shoff,) = struct.unpack_from("<I", d, 0x20)
        self.shentsize, self.shnum, self.shstrndx = struct.unpack_from("<HHH", d, 0x2E)
        self.sections = []
        for i in range(self.shnum):
            name, typ, flags, addr, off, size, link, info, align, entsize = struct.unpack_from(
                "<IIIIIIIIII", d, self.shoff + i * self.shentsize
            )
            self.sections.append(
                dict(name_off=name, type=typ, flags=flags, addr=addr, offset=off,
                     size=size, link=link, entsize=entsize)
            )
        strtab = self.sections[self.shstrndx]
        for s in self.sections:
            s["name"] = self._string(strtab["offset"], s["name_off"])

    def _string(self, base, off):
        end = self.data.index(b"\0", base + off)
        return self.data[base + off:end].decode("utf-8", "replace")

    def symbols(self):
        """(name, address, size, section name or None) of every named symbol."""
        out = []
        for s in self.sections:
            if s["type"] != 2:  # SHT_SYMTAB
                continue
            names = self.sections[s["link"]]["offset"]
            for i in range(s["size"] // s["entsize"]):
                name, value, size, info, other, shndx = struct.unpack_from(
                    "<IIIBBH", self.data, s["offset"] + i * s["entsize"]
                )
                if name == 0:
                    continue
                section = self.sections[shndx]["name"] if 0 < shndx < self.shnum else None
                out.append((self._string(names, name), value, size, section, info & 0xF))
        return out

    def symbol(self, name):
        for sym in self.symbols():
            if sym[0] == name:
                return sym
        raise KeyError(name)
