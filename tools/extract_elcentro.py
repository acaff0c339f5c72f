"""Build-time data: the 1940 El Centro N-S record, extracted from the ``quakeio`` 0.1.21 wheel
(``make elcentro`` downloads the wheel from the package index and runs this).

Usage: ``python tools/extract_elcentro.py WHEEL OUT``: writes the samples one value per line
(in g), checking the SHA-256 of the wheel and of the result (README, "Seismic records").
"""

from __future__ import annotations

import hashlib
import sys
import zipfile
from pathlib import Path

#: Checksums of the quakeio 0.1.21 wheel and of the extracted one-column file.
QUAKEIO_WHEEL_SHA256 = "efad0389f0ebf649e47d27296672571bb5a13806bde922e9582524032f3b5fe6"
ELCENTRO_SHA256 = "5a2830bc63875343df63618762503f976a2d243f978c0cf20b16a5fa66a7b37e"


def extract_elcentro(wheel: Path, out: Path) -> Path:
    """Write the El Centro samples of the ``quakeio`` wheel to ``out``; SystemExit with the
    reason where a checksum differs."""
    if hashlib.sha256(wheel.read_bytes()).hexdigest() != QUAKEIO_WHEEL_SHA256:
        raise SystemExit(f"{wheel}: not the quakeio 0.1.21 wheel (SHA-256 differs)")
    with zipfile.ZipFile(wheel) as archive:
        source = archive.read("quakeio/elcentro.py").decode()
    body = source[source.index("[") + 1:source.index("]")]
    text = "\n".join(v.strip() for v in body.split(",") if v.strip()) + "\n"
    if hashlib.sha256(text.encode()).hexdigest() != ELCENTRO_SHA256:
        raise SystemExit(f"{wheel}: the extracted record differs from the expected one")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    return out


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    print("wrote", extract_elcentro(Path(sys.argv[1]), Path(sys.argv[2])))
