"""Adapters of real vision models (Hugging Face transformers on PyTorch) as segmenters and encoders.

Install them with the optional extra ``models``. Weights are read only from the local folder
given as ``params.weights`` (saved with ``save_pretrained``); nothing is ever downloaded.
The configuration models (``config``) import neither torch nor transformers.
"""
