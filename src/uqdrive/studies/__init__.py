"""Experiment families: each turns the config into the datasets and tables of one part of the
seeds (KLE, PCE, identification, emcee, control, wheel slip) and the scorecard rows.
"""
