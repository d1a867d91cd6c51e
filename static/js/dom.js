// Tiny DOM helpers. Text from the server is only ever set as textContent.

function element( tag, className, text ) {

	const el = document.createElement( tag );
	if ( className ) el.className = className;
	if ( text !== undefined ) el.textContent = text;
	return el;

}

/** A checkbox inside its visible label. */
function checkbox( text, checked, ariaLabel ) {

	const label = element( 'label', 'check' );
	const input = element( 'input' );
	input.type = 'checkbox';
	input.checked = checked;
	if ( ariaLabel ) input.setAttribute( 'aria-label', ariaLabel );
	label.append( input, document.createTextNode( ` ${text}` ) );
	return { label, input };

}

function button( text, ariaLabel, className = 'btn' ) {

	const el = element( 'button', className, text );
	el.type = 'button';
	if ( ariaLabel ) el.setAttribute( 'aria-label', ariaLabel );
	return el;

}

/** Set textContent only when it changes (no needless layout work). */
function setText( el, text ) {

	if ( el.textContent !== text ) el.textContent = text;

}

export { button, checkbox, element, setText };
