"""Full-body validation in MuJoCo: Aliengo + a Z1-like arm under model-based controllers."""
