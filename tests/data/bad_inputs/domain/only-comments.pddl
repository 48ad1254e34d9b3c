; expect: 3 empty file
; nothing here
;; (define (domain x))
