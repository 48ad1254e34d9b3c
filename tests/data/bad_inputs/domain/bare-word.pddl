; expect: 3 :2:1: expected '(define ...)', found 'place1d'
place1d
