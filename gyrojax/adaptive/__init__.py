"""The test campaign as a loop: from the records so far, the next test on the lab's table, until the model is right
and sharp enough.

A laboratory's question is "given what I have measured, what should the table do next, and when can I stop?".
Hu's classical procedure (multi-position, then tumble, then servo; Hu ch. 3) answers it before anything is known
about the gyro. Here each step diagnoses the records (:func:`gyrojax.diagnose`), adds what the data ask for, states
what still stands between the data and the goal as *requirements* (a σ above its target, an undetected candidate of
a size that matters, an alias no record separates), and designs by gradients the static test on the lab's table
that meets them in the fewest table hours.

    goal        the goal (target σ per coefficient, the candidates to rule out) and the campaign's error budget
    lab         the laboratory's table: axes, mounting, limits, settle time, hours
    hand        a hand-held triad's lab (a person turning a box) and its next session, designed after the records
    requirements  what stands between the data and the goal, as σ ratios of sub-models of one Fisher information
    information   Fisher information of the records so far and of a candidate test
    reach       what no orientation of the table can separate, and what table would
    design      the gradient search of the next test and the hours it needs
    step        one step: diagnose, add, require, design (``gj.next_test``, ``gyrojax next``)
    classical   the hours Hu's classical sequence needs for the same σ
    bound       the fewest hours any static test on the table needs for a model's σ (a convex-duality bound)
    simulated   the loop end to end on a simulated laboratory (``gj.run_campaign``, ``gyrojax campaign``; a hand-held
                triad's, ``gj.run_hand_campaign``)
"""
