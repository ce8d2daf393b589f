"""Evaluation: run policies for whole episodes and summarise them."""
