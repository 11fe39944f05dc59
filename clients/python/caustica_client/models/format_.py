from enum import StrEnum

class Format(StrEnum):
    EXR = "exr"
    PNG = "png"

    def __str__(self) -> str:
        return str(self.value)
