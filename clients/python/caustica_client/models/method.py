from enum import StrEnum

class Method(StrEnum):
    AUTO = "auto"
    BEAMS = "beams"
    CSL = "csl"
    DIRECT = "direct"
    PHOTONS = "photons"
    PINHOLE = "pinhole"
    REFERENCE = "reference"
    TRANSPORT = "transport"
    WATER = "water"

    def __str__(self) -> str:
        return str(self.value)
