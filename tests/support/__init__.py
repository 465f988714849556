"""Helpers the test folders share: `harness` drives the sans-IO core and the physics without a
server, `clients` holds pylibfranka motions and recoveries the client tests repeat."""
