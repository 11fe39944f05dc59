from enum import StrEnum

class JobKind(StrEnum):
    BAKE = "bake"
    RENDER = "render"

    def __str__(self) -> str:
        return str(self.value)
