"""Hierarchical value estimation (RLHC) composed with TorchRL's PPO loss."""
