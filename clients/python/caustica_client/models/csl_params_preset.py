from enum import StrEnum

class CslParamsPreset(StrEnum):
    FAST = "fast"
    PAPER = "paper"

    def __str__(self) -> str:
        return str(self.value)
