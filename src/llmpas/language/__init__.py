"""llmpas.language"""
