from enum import StrEnum

class Strategy(StrEnum):
    GRID = "grid"
    NEIGHBOURHOOD = "neighbourhood"
    QUANTIZED = "quantized"
    RANDOM = "random"

    def __str__(self) -> str:
        return str(self.value)
