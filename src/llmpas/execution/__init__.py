"""llmpas.execution"""
