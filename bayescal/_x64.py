"""JAX in double precision, before any array is made.

Every module of bayescal that uses JAX imports this one first: the likelihoods sum hundreds of
terms whose differences carry the information (a float32 Whittle sum loses the rate random
walk), and JAX fixes its precision when its first array is created.
"""

import jax

jax.config.update("jax_enable_x64", True)
