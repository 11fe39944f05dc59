from enum import StrEnum

class ToneMap(StrEnum):
    ACES = "aces"
    CLAMP = "clamp"
    REINHARD = "reinhard"

    def __str__(self) -> str:
        return str(self.value)
