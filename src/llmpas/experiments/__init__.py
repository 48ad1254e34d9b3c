"""llmpas.experiments"""
