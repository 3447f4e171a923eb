"""Neural NARX: an ensemble of multilayer perceptrons on the regressor (the paper's 2 x 25 network).

- :mod:`.narx`: :class:`NeuralNARX`;
- :mod:`._kernels`: the compiled free run of the network (private to this family).
"""

from neckid.models.neural.narx import NeuralNARX, forward_pass, member_seeds

__all__ = ["NeuralNARX", "forward_pass", "member_seeds"]
