"""Figures of the report, one module per experiment family, made from datasets on disk;
`figure` holds the shared atomic PNG writer and the 2 x 2 state layout.
"""
