from enum import StrEnum

class Bounds(StrEnum):
    HULL = "hull"
    TOUCHING_PLANES = "touching_planes"

    def __str__(self) -> str:
        return str(self.value)
