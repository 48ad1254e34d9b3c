"""llmpas.worlds"""
