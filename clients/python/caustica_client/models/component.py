from enum import StrEnum

class Component(StrEnum):
    CAUSTICS = "caustics"
    DIRECT = "direct"
    INDIRECT = "indirect"
    SPECULAR = "specular"
    TOTAL = "total"
    VOLUME = "volume"
    VOLUME_CAUSTICS = "volume_caustics"

    def __str__(self) -> str:
        return str(self.value)
