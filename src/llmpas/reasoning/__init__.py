"""llmpas.reasoning"""
