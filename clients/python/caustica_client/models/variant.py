from enum import StrEnum

class Variant(StrEnum):
    PIXEL = "pixel"
    SHADER = "shader"
    SHADER_TEXTURE = "shader_texture"
    TEXTURE = "texture"
    VERTEX = "vertex"

    def __str__(self) -> str:
        return str(self.value)
