"""Experiments: shipped cases, the paper reproduction, figures and reports."""
