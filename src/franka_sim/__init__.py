"""franka-sim: a simulated Franka FR3 that libfranka clients cannot tell from the robot."""



def __getattr__(name: str):
    # Lazy so `import franka_sim` stays cheap for the CLI's --help and for tools (and so
    # `franka-sim serve` takes over SIGTERM early: see serving.py).
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            return version("franka-sim")
        except PackageNotFoundError:  # running from a source tree
            return "0.0.0"
    if name == "FrankaSim":
        from franka_sim.server.sim import FrankaSim

        return FrankaSim
    if name == "Config":
        from franka_sim.config import Config

        return Config
    raise AttributeError(name)


__all__ = ["FrankaSim", "Config", "__version__"]
