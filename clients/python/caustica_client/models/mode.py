from enum import StrEnum

class Mode(StrEnum):
    ARTICLE = "article"
    PHYSICAL = "physical"

    def __str__(self) -> str:
        return str(self.value)
