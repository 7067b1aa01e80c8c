from .model import Camera, DistantLight, Environment, Material, Mesh, Scene, Sphere, Texture

__all__ = ["Camera", "DistantLight", "Environment", "Material", "Mesh", "Scene", "Sphere", "Texture"]
