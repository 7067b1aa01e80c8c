from .model import Camera, Environment, Material, Mesh, Scene, Sphere

__all__ = ["Camera", "Environment", "Material", "Mesh", "Scene", "Sphere"]
